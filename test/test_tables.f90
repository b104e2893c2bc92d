!> Tests of `holosym tables`, run as an executable: the --quick subset reproduces the
!! best-combination orders 2M and reports a known-singular configuration as singular (read
!! from the CSV files of --csv), the Markdown goes to standard output, and bad options are
!! rejected with exit status 2.
module test_tables
    use holosym_kinds, only: wp
    use holosym_status_codes, only: HOLOSYM_SUCCESS, HOLOSYM_SINGULAR_MATRIX, real_str, int_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, split_field
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, scratch_path, &
        read_lines, any_line_contains, words
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

    !> Field k of a CSV line as an integer (-huge when it is not one).
    integer function int_field(line, k) result(value)
        character(len=*), intent(in) :: line !! CSV line
        integer, intent(in) :: k             !! field number
        character(len=:), allocatable :: text
        integer :: ios
        text = split_field(line, k, ",")
        read (text, *, iostat=ios) value
        if (ios /= 0) value = -huge(1)
    end function int_field

    !> Field k of a CSV line as a real (-huge when it is not one).
    real(wp) function real_field(line, k) result(value)
        character(len=*), intent(in) :: line !! CSV line
        integer, intent(in) :: k             !! field number
        character(len=:), allocatable :: text
        integer :: ios
        text = split_field(line, k, ",")
        read (text, *, iostat=ios) value
        if (ios /= 0) value = -huge(1.0_wp)
    end function real_field

    !> `tables --quick --csv DIR` on the pendulum: for N = M - 1 both orders are 2M;
    !! (M, N) = (2, 0) is singular (the pendulum's rotational symmetry) for every G tried.
    subroutine quick_tables(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: table1(:), table3(:)
        character(len=:), allocatable :: dir
        integer :: i, ios, best, order_m, order_n, code
        real(wp) :: energy_order, global_order
        logical :: singular_20, found_20, found_21

        dir = scratch_path("tables_quick")
        call run_holosym(words("tables", "--quick", "--csv", dir), result)
        call check(error, len(result%failure) == 0, result%failure)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "tables --quick exits " // &
            int_str(result%exit_code))
        call check(error, any_line_contains(result%out, "#### Table 1: order of the energy " // &
            "error") .and. any_line_contains(result%out, "#### Table 3:"), &
            "the Markdown tables on standard output")
        ! Progress: k/N of Table 1's 12 cells with the time, and each failed cell's reason.
        call check(error, any_line_contains(result%err, "/12, ") .and. &
            any_line_contains(result%err, " elapsed, ") .and. &
            any_line_contains(result%err, ", failed: singular matrix: "), &
            "progress lines with k/N, the time and the reason of a failed cell")
        if (allocated(error)) return
        call read_lines(dir // "/table1.csv", table1, ios)
        call check(error, ios == 0 .and. size(table1) == 13, "table1.csv: header + 12 cells")
        if (allocated(error)) return
        best = 0
        singular_20 = .false.
        do i = 2, size(table1)
            associate (line => table1(i)%text)
                order_m = int_field(line, 2)
                order_n = int_field(line, 3)
                code = int_field(line, 6)
                energy_order = real_field(line, 11)
                global_order = real_field(line, 16)
            end associate
            if (order_n == order_m - 1) then
                best = best + 1
                call check(error, code == HOLOSYM_SUCCESS .and. abs(energy_order - &
                    2 * order_m) <= order_slack, "energy order " // real_str(energy_order) // &
                    " for M = " // int_str(order_m))
                call check(error, abs(global_order - 2 * order_m) <= order_slack, &
                    "global order " // real_str(global_order) // " for M = " // int_str(order_m))
            end if
            if (order_m == 2 .and. order_n == 0) singular_20 = code == HOLOSYM_SINGULAR_MATRIX
        end do
        call check(error, best == 3, "expected 3 best-combination cells, got " // int_str(best))
        call check(error, singular_20, "(2, 0, 3) not reported singular")
        call read_lines(dir // "/table3.csv", table3, ios)
        call check(error, ios == 0 .and. size(table3) == 13, "table3.csv: header + 12 cells")
        if (allocated(error)) return
        found_20 = .true.
        found_21 = .false.
        do i = 2, size(table3)
            associate (line => table3(i)%text)
                if (int_field(line, 2) == 2 .and. int_field(line, 3) == 0) &
                    found_20 = int_field(line, 4) /= 0
                if (int_field(line, 2) == 2 .and. int_field(line, 3) == 1) &
                    found_21 = int_field(line, 4) > 0
            end associate
        end do
        call check(error, .not. found_20, "(M, N) = (2, 0): a nonsingular G found")
        call check(error, found_21, "(M, N) = (2, 1): no nonsingular G")
    end subroutine quick_tables

    !> Bad options of `tables` are rejected: exit status 2, a message and the hint.
    subroutine options_rejected(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: bad(*) = [character(len=32) :: "--Mmax 0", "--Nmax -1", &
            "--h 0.5", "--h 0.25,0.5", "--h 0.5,x", "--T -1", "--system moon", "--frobnicate", &
            "--csv"]
        type(command_result_t) :: result
        integer :: i
        do i = 1, size(bad)
            call run_holosym("tables " // trim(bad(i)), result)
            call check(error, result%exit_code == 2 .and. size(result%err) == 2, &
                "accepted: " // trim(bad(i)) // " (exit " // int_str(result%exit_code) // ")")
            if (allocated(error)) return
            call check(error, index(result%err(1)%text, "holosym tables: ") == 1 .and. &
                len(result%err(1)%text) > len("holosym tables: ") .and. &
                result%err(2)%text == "Run 'holosym tables --help' for the options.", &
                "message for " // trim(bad(i)) // ": " // result%err(1)%text)
        end do
    end subroutine options_rejected

end module test_tables
