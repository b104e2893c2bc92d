!> Tests of the lagrange part of holosym.
module test_lagrange
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    implicit none
    private
    public :: lagrange_tests
contains
    !> The tests of this suite.
    function lagrange_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        allocate (tests(0))
    end function lagrange_tests
end module test_lagrange
