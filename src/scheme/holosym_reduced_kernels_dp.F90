!> category: internal module (use holosym)
!! The reduced step's arithmetic in real64: the template
!! include/holosym_reduced_kernels.inc with rk = dp.
module holosym_reduced_kernels_dp
    use holosym_kinds, only: rk => dp
    implicit none
    private
    public :: allocate_evaluation, gather_unknowns, gauss_positions, multiplier_forces, node_sums, &
        momentum_rows

    !> SHA-256 of include/holosym_reduced_kernels.inc as compiled into this module
    !! (tools/include_digest.sh keeps it current; the test suite compares it with the file).
    character(len=*), parameter, public :: template_sha256 = &
        "431cc122b7cf07b049add81cea206341a312b03d97d8f040c859ca064d05f2ce"

#include "holosym_reduced_kernels.inc"

end module holosym_reduced_kernels_dp
