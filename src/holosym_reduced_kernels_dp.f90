!> The reduced step's arithmetic (template holosym_reduced_kernels.inc) with rk = dp.
module holosym_reduced_kernels_dp
    use holosym_kinds, only: rk => dp
    implicit none
    private
    public :: allocate_evaluation, gather_unknowns, gauss_positions, multiplier_forces, node_sums, &
        momentum_rows

    include "holosym_reduced_kernels.inc"

end module holosym_reduced_kernels_dp
