!> Jacobian assembly of the discrete scheme in working precision (the template
!! holosym_assembly.inc with rk = wp): the full-accuracy Jacobian of the plain path.
module holosym_assembly_wp
    use holosym_kinds, only: rk => wp
    implicit none
    private
    public :: assemble_blocks

    include "holosym_assembly.inc"

end module holosym_assembly_wp
