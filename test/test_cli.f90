!> Tests of the cli part of holosym.
module test_cli
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    implicit none
    private
    public :: cli_tests
contains
    !> The tests of this suite.
    function cli_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        allocate (tests(0))
    end function cli_tests
end module test_cli
