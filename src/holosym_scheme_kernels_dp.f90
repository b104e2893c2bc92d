!> category: internal module (use holosym)
!! The discrete scheme's kernels in real64 (the template holosym_scheme_kernels.inc with
!! rk = dp): the residual of the real64 pre-solve and the Jacobian of the mixed-precision
!! Newton solver, which factors in real64 anyway.
module holosym_scheme_kernels_dp
    use holosym_kinds, only: rk => dp
    implicit none
    private
    public :: assemble_blocks, set_step_constants, allocate_step_constants, allocate_hessians, &
        gauss_state, &
        d_sums, momentum_rows

    include "holosym_scheme_kernels.inc"

end module holosym_scheme_kernels_dp
