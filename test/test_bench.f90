!> Tests of the `bench` command's bookkeeping: the CSV files (round trip, malformed input
!! reported with the file, line and field, the caller's rows unchanged), the summary's choice
!! of the cheapest configuration per target and its ratios, and one tiny sweep run
!! in-process end to end (files written, errors measured, `--summarize` reproducing it).
module test_bench
    use, intrinsic :: iso_fortran_env, only: real64, int64
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status, only: holosym_status_t, int_str, real_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NEWTON_DIVERGED
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close, &
        check_status_code, split_field
    use holosym_benchmark, only: bench_row_t, bench_span
    use holosym_cli_common, only: split_words, EXIT_OK, EXIT_FAILURE
    use holosym_cli_bench, only: read_bench_csv, write_bench_csv, write_summary, &
        bench_command
    implicit none
    private
    public :: bench_tests

    !> The competitor's (GNI_COMP) real128 times for the spherical pendulum at 1e-10 and the
    !! double time at 1e-10, as in the fixed competitor table (inputs of the summary, not its
    !! output).
    real(real64), parameter :: issue_table_pendulum_1e10_real128 = 1.6e-3_real64
    real(real64), parameter :: issue_table_pendulum_1e10_double = 3.7e-5_real64
    !> Scratch directory of the end-to-end run (removed afterwards).
    character(len=*), parameter :: scratch_dir = "build/holosym_test_bench"

contains

    !> The tests of this suite.
    function bench_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("csv_round_trip_exact", test_csv_round_trip), &
            new_test("csv_rejects_malformed_input", test_csv_malformed), &
            new_test("summary_picks_cheapest_successful_run", test_summary_cheapest), &
            new_test("summary_per_step_ratios", test_summary_per_step), &
            new_test("command_tiny_sweep_end_to_end", test_command_end_to_end)]
    end function bench_tests

    ! ------------------------------------------------------------------ helpers

    !> A sweep row with the fields the summary uses.
    function make_row(system, method, precision, order_m, h, error, seconds, code) result(row)
        character(len=*), intent(in) :: system, method, precision
        integer, intent(in) :: order_m
        real(wp), intent(in) :: h, error
        real(real64), intent(in) :: seconds
        integer, intent(in) :: code
        type(bench_row_t) :: row
        row%system = system
        row%method = method
        row%precision = precision
        row%order_m = order_m
        row%order_n = max(order_m - 1, 0)
        row%gauss_points = order_m + 1
        row%order = 2 * order_m
        row%h = h
        row%steps = nint(10 / h)
        row%error = error
        row%seconds = seconds
        row%code = code
    end function make_row

    !> A success status with an empty message (messages are read in the checks).
    pure function fresh_status() result(status)
        type(holosym_status_t) :: status
        status = holosym_status_t(HOLOSYM_SUCCESS, "")
    end function fresh_status

    !> Every line of a unit (rewound first).
    subroutine read_lines(unit, lines, count)
        integer, intent(in) :: unit
        character(len=1000), allocatable, intent(out) :: lines(:)
        integer, intent(out) :: count
        character(len=1000) :: buffer
        integer :: ios
        allocate (lines(0))
        count = 0
        rewind (unit)
        do
            read (unit, '(a)', iostat=ios) buffer
            if (ios /= 0) exit
            lines = [character(len=1000) :: lines, buffer]
            count = count + 1
        end do
    end subroutine read_lines

    !> The summary line of a target and system in a given precision section, or "".
    function summary_line(lines, section, target, system) result(line)
        character(len=1000), intent(in) :: lines(:)
        character(len=*), intent(in) :: section, target, system
        character(len=:), allocatable :: line
        integer :: i
        logical :: inside
        line = ""
        inside = .false.
        do i = 1, size(lines)
            if (index(lines(i), "## ") == 1) inside = trim(lines(i)) == "## " // section
            if (inside .and. index(lines(i), "| " // target // " | " // system // " |") == 1) &
                line = trim(lines(i))
        end do
    end function summary_line

    !> Cell k (1-based) of a Markdown table row "| cell 1 | cell 2 | ... |", trimmed.
    function cell(line, k) result(text)
        character(len=*), intent(in) :: line
        integer, intent(in) :: k
        character(len=:), allocatable :: text
        text = trim(adjustl(split_field(line, k + 1, "|")))
    end function cell

    !> The lines write_summary prints for these rows.
    subroutine summary_of(rows, steps, lines, count)
        type(bench_row_t), intent(in) :: rows(:), steps(:)
        character(len=1000), allocatable, intent(out) :: lines(:)
        integer, intent(out) :: count
        integer :: unit
        open (newunit=unit, status="scratch", action="readwrite")
        call write_summary(rows, steps, unit)
        call read_lines(unit, lines, count)
        close (unit)
    end subroutine summary_of

    !> Write lines to a file.
    subroutine write_file(path, lines)
        character(len=*), intent(in) :: path
        character(len=*), intent(in) :: lines(:)
        integer :: unit, i
        open (newunit=unit, file=path, status="replace", action="write")
        do i = 1, size(lines)
            write (unit, '(a)') trim(lines(i))
        end do
        close (unit)
    end subroutine write_file

    ! ------------------------------------------------------------------ tests

    !> Rows written by write_bench_csv come back field for field, to the last bit.
    subroutine test_csv_round_trip(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: path = "holosym_test_bench_round_trip.csv"
        type(bench_row_t) :: written(3)
        type(bench_row_t), allocatable :: read_back(:)
        type(holosym_status_t) :: status
        integer :: unit, i

        status = fresh_status()
        written(1) = make_row("pendulum", "holosym", "real128", 7, 1 / 7.0_wp, &
                              sqrt(2.0_wp) * 1.0e-27_wp, 0.123456789_real64, HOLOSYM_SUCCESS)
        written(1)%energy_error = 1 / 3.0_wp * 1.0e-30_wp
        written(1)%constraint_residual = 3 * epsilon(1.0_wp)
        written(1)%newton_iterations = 5000000000_int64
        written(1)%residuals = 123_int64
        written(1)%gradients = 4567_int64
        written(1)%hessians = 89_int64
        written(1)%factorizations = 3000000000_int64
        written(2) = make_row("linkage", "rattle-suzuki", "real64", 0, 0.0884_wp, 0.25_wp, &
                              1.5_real64, HOLOSYM_NEWTON_DIVERGED)
        written(3) = make_row("pendulum", "variant-9", "real128", 2, 0.125_wp, 1.0e-9_wp, &
                              2.0e-3_real64, HOLOSYM_SUCCESS)
        written(3)%difference = 1.9e-34_wp
        call write_bench_csv(path, written, status)
        call check(error, status%ok(), "write: " // status%message)
        allocate (read_back(0))
        call read_bench_csv(path, read_back, status)
        open (newunit=unit, file=path, status="old")
        close (unit, status="delete")
        call check(error, status%ok(), "read: " // status%message)
        call check(error, size(read_back) == size(written), int_str(size(read_back)) // &
            " rows read back")
        if (allocated(error)) return
        do i = 1, size(written)
            associate (a => written(i), b => read_back(i))
                call check(error, a%system == b%system .and. a%method == b%method .and. &
                    a%precision == b%precision, "row " // int_str(i) // ": names")
                call check(error, a%order_m == b%order_m .and. a%order_n == b%order_n .and. &
                    a%gauss_points == b%gauss_points .and. a%order == b%order .and. &
                    a%steps == b%steps .and. a%code == b%code, "row " // int_str(i) // &
                    ": integers")
                call check(error, a%newton_iterations == b%newton_iterations .and. &
                    a%residuals == b%residuals .and. a%gradients == b%gradients .and. &
                    a%hessians == b%hessians .and. a%factorizations == b%factorizations, &
                    "row " // int_str(i) // ": 64-bit counters")
                call check(error, a%h == b%h .and. a%error == b%error .and. &
                    a%energy_error == b%energy_error .and. &
                    a%constraint_residual == b%constraint_residual .and. &
                    a%difference == b%difference, "row " // int_str(i) // &
                    ": reals exact (error " // real_str(b%error) // ")")
                call check(error, a%seconds == b%seconds, "row " // int_str(i) // ": seconds")
            end associate
        end do
    end subroutine test_csv_round_trip

    !> Malformed files fail with a message naming the file, line and field, and leave the
    !! caller's rows as they were; a missing file is an error unless optional.
    subroutine test_csv_malformed(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: path = "holosym_test_bench_malformed.csv"
        character(len=*), parameter :: good_row = "pendulum,holosym,real128,2,1,3,4," // &
            "1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2,1.25E-4,400,500,600,70,80,0,0"
        type(bench_row_t) :: row
        type(bench_row_t), allocatable :: rows(:)
        type(holosym_status_t) :: status
        character(len=1000) :: header
        integer :: unit

        ! The header as write_bench_csv writes it.
        status = fresh_status()
        row = make_row("pendulum", "holosym", "real128", 1, 1.0_wp, 1.0_wp, 1.0_real64, 0)
        call write_bench_csv(path, [row], status)
        open (newunit=unit, file=path, status="old", action="read")
        read (unit, '(a)') header
        close (unit)

        call expect_failure([character(len=1000) :: "system,method", good_row], &
            "header", [character(len=24) :: "line 1", "header"])
        call expect_failure([character(len=1000) :: header, good_row, &
            "pendulum,holosym,real128,2,1,3"], "too few fields", [character(len=24) :: "line 3", "21"])
        call expect_failure([character(len=1000) :: header, good_row // ",7"], &
            "too many fields", [character(len=24) :: "line 2", "21"])
        call expect_failure([character(len=1000) :: header, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,oops,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0"], "error not a number", [character(len=24) :: "line 2", "error", "oops"])
        call expect_failure([character(len=1000) :: header, &
            "pendulum,holosym,real128,2,x,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0"], "N not a number", [character(len=24) :: "line 2", "field N"])
        call expect_failure([character(len=1000) :: header, &
            "pendulum,variant-12,real128,2,1,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0"], "unknown option set", [character(len=24) :: "line 2", "variant-12"])

        ! The good file for comparison: one row appended to the caller's one.
        call write_file(path, [character(len=1000) :: header, good_row])
        rows = [row]
        status = fresh_status()
        call read_bench_csv(path, rows, status)
        call check(error, status%ok() .and. size(rows) == 2, "the well-formed file reads: " &
            // status%message)
        open (newunit=unit, file=path, status="old")
        close (unit, status="delete")

        ! Missing files.
        rows = [row]
        status = fresh_status()
        call read_bench_csv(path, rows, status, optional_file=.true.)
        call check(error, status%ok() .and. size(rows) == 1, "a missing optional file is no error")
        call read_bench_csv(path, rows, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "missing file")
        call check(error, index(status%message, path) > 0, "names the file: " // status%message)

    contains

        subroutine expect_failure(lines, what, fragments)
            character(len=*), intent(in) :: lines(:)
            character(len=*), intent(in) :: what
            character(len=*), intent(in) :: fragments(:)
            integer :: k
            call write_file(path, lines)
            rows = [row]
            status = fresh_status()
            call read_bench_csv(path, rows, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, what)
            call check(error, size(rows) == 1, what // ": the caller's rows unchanged")
            call check(error, index(status%message, path) > 0, what // ": names the file: " &
                // status%message)
            do k = 1, size(fragments)
                call check(error, index(status%message, trim(fragments(k))) > 0, what // &
                    ": message mentions '" // trim(fragments(k)) // "': " // status%message)
            end do
        end subroutine expect_failure

    end subroutine test_csv_malformed

    !> Per target, the summary shows the cheapest successful run below it (not a failed
    !! one, not the plain path, not a NaN error), the cheapest RATTLE run, the
    !! competitor table's time and the ratios table / holosym and RATTLE / holosym.
    subroutine test_summary_cheapest(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(bench_row_t), allocatable :: rows(:)
        type(bench_row_t) :: steps(0)
        character(len=1000), allocatable :: lines(:)
        character(len=:), allocatable :: line
        real(wp) :: nan
        integer :: count
        real(real64), parameter :: best_seconds = 4.0e-3_real64, rattle_seconds = 4.0e-2_real64
        character(len=16) :: expected

        nan = ieee_value(nan, ieee_quiet_nan)
        rows = [ &
            make_row("pendulum", "holosym", "real128", 5, 0.5_wp, 5.0e-11_wp, 1.0e-2_real64, 0), &
            make_row("pendulum", "holosym", "real128", 6, 1.0_wp, 1.0e-12_wp, best_seconds, 0), &
            make_row("pendulum", "holosym", "real128", 7, 1.0_wp, 1.0e-11_wp, 1.0e-3_real64, &
                     HOLOSYM_NEWTON_DIVERGED), &
            make_row("pendulum", "holosym-plain", "real128", 7, 1.0_wp, 1.0e-12_wp, &
                     5.0e-4_real64, 0), &
            make_row("pendulum", "holosym", "real128", 8, 1.0_wp, nan, 1.0e-4_real64, 0), &
            make_row("pendulum", "holosym", "real128", 3, 1.0_wp, 2.0e-10_wp, 2.0e-4_real64, 0), &
            make_row("pendulum", "rattle-suzuki", "real128", 0, 0.25_wp, 1.0e-11_wp, &
                     rattle_seconds, 0), &
            make_row("pendulum", "rattle-triple-jump", "real128", 0, 0.125_wp, 1.0e-13_wp, &
                     8.0e-2_real64, 0)]
        call summary_of(rows, steps, lines, count)

        line = summary_line(lines, "real128", "1.00000E-0010", "pendulum")
        call check(error, len(line) > 0, "a real128 line for 1e-10, pendulum")
        if (allocated(error)) return
        call check(error, cell(line, 3) == "(6,5,7) h=1.000", "cheapest holosym: " // line)
        call check(error, cell(line, 4) == "4.00E-03", "its seconds: " // cell(line, 4))
        call check(error, cell(line, 5) == "suzuki p=0 h=0.2500", "cheapest RATTLE: " // line)
        call check(error, cell(line, 7) == "1.60E-03", "the competitor table's time: " // cell(line, 7))
        write (expected, '(f10.1)') issue_table_pendulum_1e10_real128 / best_seconds
        call check(error, cell(line, 8) == trim(adjustl(expected)), "x table " // &
            cell(line, 8) // ", expected " // trim(adjustl(expected)))
        write (expected, '(f10.1)') rattle_seconds / best_seconds
        call check(error, cell(line, 9) == trim(adjustl(expected)), "x RATTLE " // cell(line, 9))

        ! 1e-6: the fast order-6 run that misses 1e-10 is the cheapest; no table time there.
        line = summary_line(lines, "real128", "1.00000E-0006", "pendulum")
        call check(error, cell(line, 3) == "(3,2,4) h=1.000", "1e-6: " // line)
        call check(error, cell(line, 7) == "—" .and. cell(line, 8) == "—", "1e-6: no table")
        ! 1e-14: nothing reaches it.
        line = summary_line(lines, "real128", "1.00000E-0014", "pendulum")
        call check(error, cell(line, 3) == "—" .and. cell(line, 5) == "—", "1e-14: none: " // line)
        ! Systems without rows and precisions without rows are left out.
        call check(error, len(summary_line(lines, "real128", "1.00000E-0010", "linkage")) == 0, &
            "no linkage lines")
        call check(error, .not. any(lines(:count) == "## real64"), "no real64 section")
        if (allocated(error)) return

        ! A real64 row adds its section, against the table's double column.
        rows = [rows, make_row("pendulum", "holosym", "real64", 4, 0.5_wp, 1.0e-11_wp, &
                               1.0e-4_real64, 0)]
        call summary_of(rows, steps, lines, count)
        line = summary_line(lines, "real64", "1.00000E-0010", "pendulum")
        call check(error, cell(line, 3) == "(4,3,5) h=0.5000", "real64 line: " // line)
        write (expected, '(es9.2)') issue_table_pendulum_1e10_double
        call check(error, cell(line, 7) == trim(adjustl(expected)), "double column: " // line)
        line = summary_line(lines, "real128", "1.00000E-0010", "pendulum")
        call check(error, cell(line, 3) == "(6,5,7) h=1.000", "real128 line unchanged: " // line)
    end subroutine test_summary_cheapest

    !> The per-step table: seconds per step and the ratio to the plain path (option set 0)
    !! of the same configuration; rows that are not an option set are left out.
    subroutine test_summary_per_step(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(bench_row_t) :: rows(0)
        type(bench_row_t) :: steps(3)
        character(len=1000), allocatable :: lines(:)
        integer :: count, i, found
        character(len=16) :: expected
        steps(1) = make_row("pendulum", "variant-0", "real128", 2, 0.125_wp, 1.0_wp, &
                            0.8_real64, 0)
        steps(2) = make_row("pendulum", "variant-x", "real128", 2, 0.125_wp, 1.0_wp, &
                            0.1_real64, 0)
        steps(3) = make_row("pendulum", "variant-9", "real128", 2, 0.125_wp, 1.0_wp, &
                            0.1_real64, 0)
        steps%newton_iterations = [480_int64, 0_int64, 400_int64]
        call summary_of(rows, steps, lines, count)
        found = 0
        do i = 1, count
            if (index(lines(i), "| (2,1,3) real128 |") /= 1) cycle
            found = found + 1
            if (found == 2) then
                write (expected, '(f10.1)') 0.8_real64 / 0.1_real64
                call check(error, cell(lines(i), 4) == trim(adjustl(expected)), &
                    "x plain of option set 9: " // trim(lines(i)))
                write (expected, '(f10.1)') 400.0_real64 / steps(3)%steps
                call check(error, cell(lines(i), 5) == trim(adjustl(expected)), &
                    "Newton iterations per step: " // trim(lines(i)))
            end if
        end do
        call check(error, found == 2, int_str(found) // " per-step lines, expected 2 " // &
            "(variant-x left out)")
    end subroutine test_summary_per_step

    !> A tiny real sweep in-process: holosym M = 1 and plain RATTLE on the pendulum with a
    !! 0.01 s budget. The CSV rows are consistent (steps h = T, errors finite and shrinking
    !! with h), the reference file is well-formed, the summary goes to the output unit and
    !! summary.md, `--summarize` rebuilds the same file, and an empty directory is an error.
    subroutine test_command_end_to_end(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(bench_row_t), allocatable :: rows(:)
        type(holosym_status_t) :: status
        character(len=1000), allocatable :: out_lines(:), file_lines(:), again(:), refs(:)
        character(len=:), allocatable :: csv
        integer :: out, err, code, count, file_count, again_count, ref_count, unit, i
        integer :: first_holosym, last_holosym
        logical :: exists

        call execute_command_line("rm -rf '" // scratch_dir // "'")
        open (newunit=out, status="scratch", action="readwrite")
        open (newunit=err, status="scratch", action="readwrite")
        call bench_command(split_words("--out " // scratch_dir // " --systems pendulum " // &
            "--Mmax 1 --order 2 --budget 0.01 --no-per-step"), out, err, code)
        call check(error, code == EXIT_OK, "bench exits 0, got " // int_str(code))
        call read_lines(out, out_lines, count)
        close (out)
        close (err)
        if (allocated(error)) return

        csv = scratch_dir // "/" // merge("bench64.csv", "bench.csv  ", wp_is_double)
        status = fresh_status()
        allocate (rows(0))
        call read_bench_csv(trim(csv), rows, status)
        call check(error, status%ok(), "read " // trim(csv) // ": " // status%message)
        call check(error, size(rows) >= 4, int_str(size(rows)) // " rows")
        if (allocated(error)) return
        first_holosym = 0
        last_holosym = 0
        do i = 1, size(rows)
            call check(error, rows(i)%system == "pendulum", "system of row " // int_str(i))
            call check(error, rows(i)%method == "holosym" .or. &
                rows(i)%method == "rattle-triple-jump", "method of row " // rows(i)%method)
            call check_close(error, rows(i)%steps * rows(i)%h, bench_span("pendulum"), &
                64 * epsilon(1.0_wp), 0.0_wp, "steps h = T in row " // int_str(i))
            if (rows(i)%code == HOLOSYM_SUCCESS) call check(error, rows(i)%error > 0 .and. &
                rows(i)%error <= huge(1.0_wp), "row " // int_str(i) // ": finite error " // &
                real_str(rows(i)%error))
            call check(error, rows(i)%newton_iterations > 0 .or. rows(i)%method /= "holosym", &
                "holosym rows count Newton iterations")
            if (rows(i)%method == "holosym" .and. rows(i)%gauss_points == 1 .and. &
                rows(i)%code == HOLOSYM_SUCCESS) then
                if (first_holosym == 0) first_holosym = i
                last_holosym = i
            end if
        end do
        if (allocated(error)) return
        call check(error, last_holosym > first_holosym, "at least two (1,0,1) runs")
        if (allocated(error)) return
        ! Order 2: the error falls with h (by about the square of the step ratio).
        call check(error, rows(last_holosym)%h < rows(first_holosym)%h .and. &
            rows(last_holosym)%error < rows(first_holosym)%error, "error falls with h: " // &
            real_str(rows(first_holosym)%error) // " at h = " // real_str(rows(first_holosym)%h) &
            // ", " // real_str(rows(last_holosym)%error) // " at h = " // &
            real_str(rows(last_holosym)%h))

        ! The reference file: 3 q and 3 p values and a comment with the reference step 1/16.
        open (newunit=unit, file=scratch_dir // "/reference.csv", status="old", action="read")
        call read_lines(unit, refs, ref_count)
        close (unit)
        call check(error, count_prefix(refs(:ref_count), "pendulum,q,") == 3 .and. &
            count_prefix(refs(:ref_count), "pendulum,p,") == 3, "3 q and 3 p reference values")
        call check(error, any(index(refs(:ref_count), "# pendulum: M = 8, h = " // &
            real_str(0.0625_wp) // " and h/2") == 1), "reference comment names h = 1/16")

        ! The summary: on the output unit and in summary.md, the same lines.
        open (newunit=unit, file=scratch_dir // "/summary.md", status="old", action="read")
        call read_lines(unit, file_lines, file_count)
        close (unit)
        call check(error, file_count == count .and. file_count > 10, "summary.md has the " // &
            "lines printed: " // int_str(file_count) // " and " // int_str(count))
        if (allocated(error)) return
        call check(error, all(file_lines(:count) == out_lines(:count)), "same summary lines")
        call check(error, len(summary_line(file_lines, merge("real64 ", "real128", &
            wp_is_double), "1.00000E-0006", "pendulum")) > 0, "a line for 1e-6, pendulum")

        ! --summarize rebuilds the same summary from the CSV files.
        open (newunit=unit, file=scratch_dir // "/summary.md", status="old")
        close (unit, status="delete")
        open (newunit=out, status="scratch", action="readwrite")
        open (newunit=err, status="scratch", action="readwrite")
        call bench_command(split_words("--summarize " // scratch_dir), out, err, code)
        close (out)
        close (err)
        call check(error, code == EXIT_OK, "--summarize exits 0")
        inquire (file=scratch_dir // "/summary.md", exist=exists)
        call check(error, exists, "--summarize writes summary.md")
        if (allocated(error)) return
        open (newunit=unit, file=scratch_dir // "/summary.md", status="old", action="read")
        call read_lines(unit, again, again_count)
        close (unit)
        call check(error, again_count == file_count, "--summarize: same line count")
        if (allocated(error)) return
        call check(error, all(again(:again_count) == file_lines(:file_count)), &
            "--summarize: same lines")

        ! A directory without bench files is an error, reported on the error unit.
        call execute_command_line("rm -rf '" // scratch_dir // "' && mkdir -p '" // &
            scratch_dir // "'")
        open (newunit=out, status="scratch", action="readwrite")
        open (newunit=err, status="scratch", action="readwrite")
        call bench_command(split_words("--summarize " // scratch_dir), out, err, code)
        call read_lines(err, again, again_count)
        close (out)
        close (err)
        call execute_command_line("rm -rf '" // scratch_dir // "'")
        call check(error, code == EXIT_FAILURE, "--summarize of an empty directory exits 1")
        call check(error, again_count > 0, "and says why")
        if (again_count > 0) call check(error, index(again(1), "no bench.csv") > 0, &
            "message: " // trim(again(1)))

    contains

        pure integer function count_prefix(lines, prefix)
            character(len=1000), intent(in) :: lines(:)
            character(len=*), intent(in) :: prefix
            integer :: k
            count_prefix = 0
            do k = 1, size(lines)
                if (index(lines(k), prefix) == 1) count_prefix = count_prefix + 1
            end do
        end function count_prefix

    end subroutine test_command_end_to_end

end module test_bench
