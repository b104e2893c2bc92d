!> Tests of the quadrature part of holosym.
module test_quadrature
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    implicit none
    private
    public :: quadrature_tests
contains
    !> The tests of this suite.
    function quadrature_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        allocate (tests(0))
    end function quadrature_tests
end module test_quadrature
