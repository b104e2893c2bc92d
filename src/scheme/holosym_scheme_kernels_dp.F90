!> category: internal module (use holosym)
!! The discrete scheme's kernels in real64: the template include/holosym_scheme_kernels.inc
!! with rk = dp, for the residual of the real64 pre-solve and the Jacobian of the
!! mixed-precision Newton solver, which factors in real64 anyway.
module holosym_scheme_kernels_dp
    use holosym_kinds, only: rk => dp
    implicit none
    private

    !> SHA-256 of include/holosym_scheme_kernels.inc as compiled into this module
    !! (tools/include_digest.sh keeps it current; the test suite compares it with the file).
    character(len=*), parameter, public :: template_sha256 = &
        "a228f834904786a0b2ab2be32875dba4f979b2bfcfc00231749f426c598c55c0"

#define SCHEME_TABLES scheme_tables_dp
#define STEP_CONSTANTS step_constants_dp
#define ASSEMBLY_HESSIANS assembly_hessians_dp
#include "holosym_scheme_kernels.inc"

end module holosym_scheme_kernels_dp
