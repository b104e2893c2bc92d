!> category: internal module (use holosym)
!! The discrete scheme's kernels in working precision: the template
!! include/holosym_scheme_kernels.inc with rk = wp, for the residual of the final Newton
!! iterations and the full-accuracy Jacobian of the plain path.
module holosym_scheme_kernels_wp
    use holosym_kinds, only: rk => wp
    use holosym_scheme_layout, only: scheme_layout_t
    implicit none
    private

    !> SHA-256 of include/holosym_scheme_kernels.inc as compiled into this module
    !! (tools/include_digest.sh keeps it current; the test suite compares it with the file).
    character(len=*), parameter, public :: template_sha256 = &
        "29c56e64d2855e9c8e5cfaef7b11847660df6628852b9ed5e06a241fce1fb084"

#define SCHEME_TABLES scheme_tables_wp
#define STEP_CONSTANTS step_constants_wp
#define ASSEMBLY_HESSIANS assembly_hessians_wp
#include "holosym_scheme_kernels.inc"

end module holosym_scheme_kernels_wp
