!> Tests of the errors part of holosym.
module test_errors
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    implicit none
    private
    public :: errors_tests
contains
    !> The tests of this suite.
    function errors_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        allocate (tests(0))
    end function errors_tests
end module test_errors
