!> Tests of the `tables` study: the --quick subset, run in-process, reproduces the
!! best-combination orders 2M and reports a known-singular configuration as singular.
module test_tables
    use holosym_kinds, only: wp
    use holosym_status, only: holosym_status_t, HOLOSYM_SINGULAR_MATRIX, real_str, int_str
    use holosym_convergence, only: order_cell_t
    use holosym_cli_common, only: split_words
    use holosym_cli_tables, only: tables_options_t, tables_result_t, parse_tables_options, &
        compute_tables
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    implicit none
    private
    public :: tables_tests

    !> Allowed deviation of a measured order from the paper's 2M.
    real(wp), parameter :: order_slack = 0.3_wp

contains

    !> The tests of this suite.
    function tables_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [new_test("quick_best_combination_orders_and_singular", quick_tables), &
                 new_test("options_rejected", options_rejected)]
    end function tables_tests

    !> `tables --quick` on the pendulum: for N = M - 1 both orders are 2M; (M, N) = (2, 0)
    !! is singular (the pendulum's rotational symmetry) for every G tried.
    subroutine quick_tables(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(tables_options_t) :: options
        type(tables_result_t) :: result
        type(holosym_status_t) :: status
        integer :: i, best
        call parse_tables_options(split_words("--quick"), options, status)
        call check(error, status%ok(), "parse --quick")
        if (allocated(error)) return
        options%progress = .false.
        call compute_tables(options, result, 0, status)
        call check(error, status%ok(), "compute_tables failed")
        if (allocated(error)) return
        best = 0
        do i = 1, size(result%table1)
            associate (cell => result%table1(i))
                if (cell%order_n == cell%order_m - 1) then
                    best = best + 1
                    call check(error, cell%energy_measured .and. abs(cell%energy_order - &
                        2 * cell%order_m) <= order_slack, "energy order " // &
                        real_str(cell%energy_order) // " for M = " // int_str(cell%order_m))
                    call check(error, cell%global_measured .and. abs(cell%global_order - &
                        2 * cell%order_m) <= order_slack, "global order " // &
                        real_str(cell%global_order) // " for M = " // int_str(cell%order_m))
                end if
                if (cell%order_m == 2 .and. cell%order_n == 0) call check(error, &
                    cell%code == HOLOSYM_SINGULAR_MATRIX, "(2, 0, 3) not reported singular")
            end associate
        end do
        call check(error, best == 3, "expected 3 best-combination cells, got " // int_str(best))
        call check(error, result%min_gauss(2, 0) == 0, "(M, N) = (2, 0): a nonsingular G found")
        call check(error, result%min_gauss(2, 1) > 0, "(M, N) = (2, 1): no nonsingular G")
    end subroutine quick_tables

    !> Bad options of `tables` are rejected with a message.
    subroutine options_rejected(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(tables_options_t) :: options
        type(holosym_status_t) :: status
        character(len=*), parameter :: bad(*) = [character(len=32) :: "--Mmax 0", "--Nmax -1", &
            "--h 0.5", "--h 0.25,0.5", "--h 0.5,x", "--T -1", "--system moon", "--frobnicate", &
            "--csv"]
        integer :: i
        do i = 1, size(bad)
            call parse_tables_options(split_words(trim(bad(i))), options, status)
            call check(error, .not. status%ok() .and. len(status%message) > 0, &
                "accepted: " // trim(bad(i)))
        end do
    end subroutine options_rejected

end module test_tables
