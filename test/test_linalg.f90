!> Tests of the linalg part of holosym.
module test_linalg
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    implicit none
    private
    public :: linalg_tests
contains
    !> The tests of this suite.
    function linalg_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        allocate (tests(0))
    end function linalg_tests
end module test_linalg
