!> category: internal module (use holosym)
!! The reduced step's arithmetic in working precision: the template
!! include/holosym_reduced_kernels.inc with rk = wp.
module holosym_reduced_kernels_wp
    use holosym_kinds, only: rk => wp
    implicit none
    private
    public :: allocate_evaluation, gather_unknowns, gauss_positions, multiplier_forces, node_sums, &
        momentum_rows

    !> SHA-256 of include/holosym_reduced_kernels.inc as compiled into this module
    !! (tools/include_digest.sh keeps it current; the test suite compares it with the file).
    character(len=*), parameter, public :: template_sha256 = &
        "431cc122b7cf07b049add81cea206341a312b03d97d8f040c859ca064d05f2ce"

#include "holosym_reduced_kernels.inc"

end module holosym_reduced_kernels_wp
