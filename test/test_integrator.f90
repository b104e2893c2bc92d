!> Tests of the integrator part of holosym.
module test_integrator
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    implicit none
    private
    public :: integrator_tests
contains
    !> The tests of this suite.
    function integrator_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        allocate (tests(0))
    end function integrator_tests
end module test_integrator
