!> Tests of `holosym figures`: the quick variant writes the data of every figure with the
!! expected columns and sane values (the constraints at round-off, the energy error bounded
!! for the symplectic schemes and drifting for Runge-Kutta, the orders 2M in the
!! convergence data, the coarse and fine linkage runs on one curve), and bad options are
!! rejected. No plotting here: `make figures` draws the PNGs.
module test_figures
    use holosym_kinds, only: wp
    use holosym_status_codes, only: int_str, real_str
    use holosym_observers, only: trajectory_header
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, split_field
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, &
        scratch_path, read_lines, any_line_contains
    implicit none
    private
    public :: figures_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Round-off level of constraint residuals.
    real(wp), parameter :: round_off = 1.0e3_wp * eps

contains

    !> The tests of this suite.
    function figures_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("quick_data_of_every_figure", quick_data), &
            new_test("rejects_bad_options", bad_options)]
    end function figures_tests

    !> A CSV file of the run as lines, the header checked.
    subroutine csv_lines(error, name, header, lines)
        type(test_error_t), allocatable, intent(inout) :: error
        character(len=*), intent(in) :: name, header
        type(text_line_t), allocatable, intent(out) :: lines(:)
        integer :: ios
        call read_lines(scratch_path("figures/" // name), lines, ios)
        call check(error, ios == 0 .and. size(lines) > 1, name // " missing or empty")
        if (allocated(error)) return
        call check(error, lines(1)%text == header, name // ": header '" // lines(1)%text // "'")
    end subroutine csv_lines

    !> Column `k` of row `row` as a number.
    real(wp) function value_at(lines, row, k) result(value)
        type(text_line_t), intent(in) :: lines(:)
        integer, intent(in) :: row, k
        character(len=:), allocatable :: field
        integer :: ios
        field = split_field(lines(row)%text, k, ",")
        read (field, *, iostat=ios) value
        if (ios /= 0) value = huge(1.0_wp)
    end function value_at

    !> The largest |value| of column k over rows first..last.
    real(wp) function column_max(lines, k, first) result(biggest)
        type(text_line_t), intent(in) :: lines(:)
        integer, intent(in) :: k, first
        integer :: row
        biggest = 0
        do row = first, size(lines)
            biggest = max(biggest, abs(value_at(lines, row, k)))
        end do
    end function column_max

    subroutine quick_data(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:), fine(:)
        real(wp) :: worst, order, last(3), first_error(3)
        character(len=:), allocatable :: method
        integer :: row, k, counts(3), i
        call run_holosym("figures --quick --out " // scratch_path("figures"), result)
        call check(error, result%exit_code == 0, "holosym figures --quick: exit " // &
            int_str(result%exit_code))
        if (allocated(error)) return

        ! Fig. 1: 160 steps of h = 1/8 (t = 20), constraints at round-off.
        call csv_lines(error, "fig1_pendulum.csv", trajectory_header(3, 1), lines)
        if (allocated(error)) return
        call check(error, size(lines) == 162, "fig1: 161 rows, got " // int_str(size(lines) - 1))
        call check(error, abs(value_at(lines, size(lines), 1) - 20) <= 64 * eps, "fig1: t = 20")
        call check(error, column_max(lines, 11, 2) <= round_off, "fig1: max |phi| " // &
            real_str(column_max(lines, 11, 2)))
        call check(error, column_max(lines, 10, 2) < 1.0e-3_wp, "fig1: energy error")
        ! Fig. 2: h = 1/2; M = 7 far more accurate than M = 2, both bounded.
        call csv_lines(error, "fig2_energy_M2.csv", trajectory_header(3, 1), lines)
        if (allocated(error)) return
        worst = column_max(lines, 10, 2)
        call check(error, size(lines) == 42 .and. worst < 0.1_wp .and. worst > 1.0e-8_wp, &
            "fig2 M = 2: energy error " // real_str(worst))
        call csv_lines(error, "fig2_energy_M7.csv", trajectory_header(3, 1), lines)
        if (allocated(error)) return
        call check(error, column_max(lines, 10, 2) < 1.0e-3_wp * worst, "fig2 M = 7: " // &
            real_str(column_max(lines, 10, 2)))
        ! Fig. 4: the coarse run's balls lie on the fine run's curve.
        call csv_lines(error, "fig4_linkage_coarse.csv", trajectory_header(6, 3), lines)
        call csv_lines(error, "fig4_linkage_fine.csv", trajectory_header(6, 3), fine)
        if (allocated(error)) return
        call check(error, size(lines) == 22 .and. size(fine) == 82, "fig4: row counts")
        if (allocated(error)) return
        worst = 0
        do row = 2, size(lines)
            do k = 2, 5
                worst = max(worst, abs(value_at(lines, row, k) - &
                                       value_at(fine, 4 * (row - 2) + 2, k)))
            end do
        end do
        call check(error, worst < 1.0e-2_wp, "fig4: coarse against fine " // real_str(worst))
        ! Fig. 5: phi at every displacement node at round-off.
        call csv_lines(error, "fig5_constraints.csv", "t,step,node,phi1,phi2,phi3,phi_sum", &
                       lines)
        if (allocated(error)) return
        call check(error, size(lines) == 42, "fig5: 41 node rows, got " // &
            int_str(size(lines) - 1))
        call check(error, column_max(lines, 7, 2) <= round_off, "fig5: |phi_sum| " // &
            real_str(column_max(lines, 7, 2)))
        ! Long run: three methods; the symplectic ones bounded and on the manifold, the
        ! Runge-Kutta one drifting off it.
        call csv_lines(error, "long_run.csv", "method,step,t,energy_error," // &
            "constraint_residual,velocity_residual", lines)
        if (allocated(error)) return
        counts = 0
        first_error = -1
        do row = 2, size(lines)
            method = split_field(lines(row)%text, 1, ",")
            select case (method)
            case ("holosym")
                i = 1
            case ("rattle")
                i = 2
            case ("rk4-index1")
                i = 3
            case default
                i = 0
            end select
            call check(error, i > 0, "long: unknown method '" // method // "'")
            if (allocated(error)) return
            counts(i) = counts(i) + 1
            if (first_error(i) < 0) first_error(i) = value_at(lines, row, 4)
            last(i) = value_at(lines, row, 5)
            if (i < 3) call check(error, value_at(lines, row, 4) < 1.0e-5_wp .and. &
                value_at(lines, row, 5) <= round_off, "long: " // method // " row " // &
                int_str(row))
        end do
        call check(error, all(counts == 1000), "long: 1000 rows per method")
        call check(error, last(3) > 1.0e-10_wp, "long: Runge-Kutta's |phi| at the end " // &
            real_str(last(3)))
        call check(error, value_at(lines, size(lines), 4) > 10 * first_error(3), &
            "long: Runge-Kutta's energy error grows")
        ! Convergence: M = 1..4 at h = 1/2..1/16; the last pair of each M has order 2M.
        call csv_lines(error, "convergence.csv", "M,N,G,h,energy_error,global_error,status", &
                       lines)
        if (allocated(error)) return
        ! 4 step sizes per M (fewer where the error reaches the round-off floor first).
        call check(error, size(lines) >= 14 .and. size(lines) <= 17, "convergence: " // &
            int_str(size(lines) - 1) // " rows")
        if (allocated(error)) return
        do k = 1, 4
            ! The last pair of rows of this M with both errors above round-off.
            order = -1
            do row = 3, size(lines)
                if (nint(value_at(lines, row, 1)) /= k .or. &
                    nint(value_at(lines, row - 1, 1)) /= k) cycle
                if (value_at(lines, row, 6) <= 1.0e6_wp * eps) cycle
                order = log(value_at(lines, row - 1, 6) / value_at(lines, row, 6)) / &
                    log(2.0_wp)
            end do
            if (order < 0) cycle
            call check(error, abs(order - 2 * k) < 0.3_wp, "convergence: M = " // &
                int_str(k) // ", global order " // real_str(order))
        end do
    end subroutine quick_data

    !> No --out, an unknown figure, too few long-run steps: usage errors naming the option;
    !! a directory that cannot be made: a failure.
    subroutine bad_options(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call run_holosym("figures --quick", result)
        call check(error, result%exit_code == 2 .and. any_line_contains(result%err, "--out"), &
            "missing --out")
        call run_holosym("figures --out x --figure fig3", result)
        call check(error, result%exit_code == 2 .and. any_line_contains(result%err, "fig3"), &
            "unknown figure fig3")
        call run_holosym("figures --out x --long-steps 5", result)
        call check(error, result%exit_code == 2 .and. any_line_contains(result%err, &
            "--long-steps"), "--long-steps 5")
        call run_holosym("figures --bogus", result)
        call check(error, result%exit_code == 2 .and. any_line_contains(result%err, "--bogus"), &
            "unknown option")
        call run_holosym("figures --quick --figure fig5 --out /proc/holosym_no", result)
        call check(error, result%exit_code == 1, "uncreatable directory: exit " // &
            int_str(result%exit_code))
        call run_holosym("figures --help", result)
        call check(error, result%exit_code == 0 .and. any_line_contains(result%out, "fig5"), &
            "help")
    end subroutine bad_options

end module test_figures
