!> category: internal module (use holosym)
!! The tape evaluator in working precision, for every evaluation of a system given by
!! formulas: the template include/holosym_tape_kernels.inc with rk = wp.
module holosym_tape_kernels_wp
    use holosym_kinds, only: rk => wp
    use holosym_expression, only: op_add, op_subtract, op_multiply, op_divide, op_negate, &
        op_power_int, op_power, op_sqrt, op_exp, op_log, op_sin, op_cos, op_tan, op_atan, &
        op_sinh, op_cosh, op_tanh, op_asin, op_acos, op_atan2
    implicit none
    private

    !> SHA-256 of include/holosym_tape_kernels.inc as compiled into this module
    !! (tools/include_digest.sh keeps it current; the test suite compares it with the file).
    character(len=*), parameter, public :: template_sha256 = &
        "e9615f8e6d9d1d9f5f18154f6ea8f5154e565685798eaa5066be13e943973358"

#define TAPE_RUN run_tape_wp
#define TAPE_RUN_POINTS run_tape_points_wp
#include "holosym_tape_kernels.inc"

end module holosym_tape_kernels_wp
