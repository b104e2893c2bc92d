!> Tests of the scheme part of holosym.
module test_scheme
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    implicit none
    private
    public :: scheme_tests
contains
    !> The tests of this suite.
    function scheme_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        allocate (tests(0))
    end function scheme_tests
end module test_scheme
