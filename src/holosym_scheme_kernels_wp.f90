!> category: internal module (use holosym)
!! The discrete scheme's kernels in working precision (the template
!! holosym_scheme_kernels.inc with rk = wp): the residual of the final Newton iterations
!! and the full-accuracy Jacobian of the plain path.
module holosym_scheme_kernels_wp
    use holosym_kinds, only: rk => wp
    implicit none
    private
    public :: assemble_blocks, set_step_constants, allocate_step_constants, allocate_hessians, &
        gauss_state, &
        d_sums, momentum_rows

    include "holosym_scheme_kernels.inc"

end module holosym_scheme_kernels_wp
