!> Jacobian assembly of the discrete scheme in real64 (the template holosym_assembly.inc
!! with rk = dp): for the mixed-precision Newton solver, which factors in real64 anyway.
module holosym_assembly_dp
    use holosym_kinds, only: rk => dp
    implicit none
    private
    public :: assemble_blocks

    include "holosym_assembly.inc"

end module holosym_assembly_dp
