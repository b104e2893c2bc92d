!> Tests of `holosym bench`, run as an executable: `--summarize DIR` on CSV files written
!! here (malformed files rejected with the file, line and field and no summary written;
!! the cheapest successful configuration per target and its ratios; the runs through
!! --accuracy with their pilot, against heyoka, and their verdict; the per-step table;
!! values read to the last bit), and one tiny sweep end to end (files written, errors
!! measured, `--summarize` reproducing the summary, an empty directory an error).
module test_bench
    use, intrinsic :: iso_fortran_env, only: real64, int64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: int_str, real_str, status_code_name, HOLOSYM_SUCCESS, &
        HOLOSYM_NEWTON_DIVERGED, HOLOSYM_INVALID_ARGUMENT
    use holosym_study_text, only: int64_str, ratio_text
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close, &
        split_field
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, run_shell, &
        shell_quote, scratch_path, read_lines, write_lines, file_exists, words
    implicit none
    private
    public :: bench_tests

    !> A heyoka run's time for the spherical pendulum (an input of the summary).
    real(real64), parameter :: heyoka_seconds = 1.6e-3_real64
    !> T of the benchmark on the pendulum.
    real(wp), parameter :: pendulum_span = 10
    !> The header of the bench CSV files.
    character(len=*), parameter :: csv_header = "system,method,precision,M,N,G,order,h," // &
        "steps,error,energy_error,constraint_residual,seconds,seconds_per_step," // &
        "newton_iterations,residual_evaluations,gradient_evaluations,hessian_evaluations," // &
        "lu_factorizations,status,difference_from_plain,tolerance,compile_seconds"
    !> Exit status of a failed command.
    integer, parameter :: exit_failure = 1

    !> A row of a bench CSV file, as the tests write and read it.
    type :: row_t
        character(len=24) :: system = "", method = "", precision = ""
        integer :: order_m = 0, order_n = 0, gauss_points = 0, order = 0, steps = 0, code = 0
        real(wp) :: h = 0, error = 0, energy_error = 0, constraint_residual = 0, seconds = 0
        real(wp) :: difference = 0, tolerance = 0, compile_seconds = 0
        integer(int64) :: newton_iterations = 0, residuals = 0, gradients = 0, hessians = 0
        integer(int64) :: factorizations = 0
    end type row_t

contains

    !> The tests of this suite.
    function bench_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("csv_values_read_exactly", test_csv_exact), &
            new_test("csv_rejects_malformed_input", test_csv_malformed), &
            new_test("summary_picks_cheapest_successful_run", test_summary_cheapest), &
            new_test("summary_per_step_ratios", test_summary_per_step), &
            new_test("summary_through_accuracy", test_summary_accuracy), &
            new_test("command_tiny_sweep_end_to_end", test_command_end_to_end), &
            new_test("scaling_quick", test_scaling_quick), &
            new_test("long_quick", test_long_quick)]
    end function bench_tests

    ! ------------------------------------------------------------------ helpers

    !> A sweep row with the fields the summary uses.
    function make_row(system, method, precision, order_m, h, error, seconds, code) result(row)
        character(len=*), intent(in) :: system, method, precision
        integer, intent(in) :: order_m
        real(wp), intent(in) :: h, error
        real(real64), intent(in) :: seconds
        integer, intent(in) :: code
        type(row_t) :: row
        row%system = system
        row%method = method
        row%precision = precision
        row%order_m = order_m
        row%order_n = max(order_m - 1, 0)
        row%gauss_points = order_m + 1
        row%order = 2 * order_m
        row%h = h
        row%steps = nint(pendulum_span / h)
        row%error = error
        row%seconds = real(seconds, wp)
        row%code = code
    end function make_row

    !> A real as the bench writes it: 36 significant digits.
    function real_text(value) result(text)
        real(wp), intent(in) :: value
        character(len=:), allocatable :: text
        character(len=48) :: buffer
        write (buffer, '(es44.35e4)') value
        text = trim(adjustl(buffer))
    end function real_text

    !> The CSV line of a row.
    function row_line(row) result(line)
        type(row_t), intent(in) :: row
        character(len=:), allocatable :: line
        line = trim(row%system) // "," // trim(row%method) // "," // trim(row%precision) // &
            "," // int_str(row%order_m) // "," // int_str(row%order_n) // "," // &
            int_str(row%gauss_points) // "," // int_str(row%order) // "," // &
            real_text(row%h) // "," // int_str(row%steps) // "," // real_text(row%error) // &
            "," // real_text(row%energy_error) // "," // real_text(row%constraint_residual) // &
            "," // real_text(row%seconds) // "," // real_text(row%seconds / max(row%steps, 1)) &
            // "," // int64_str(row%newton_iterations) // "," // int64_str(row%residuals) // "," &
            // int64_str(row%gradients) // "," // int64_str(row%hessians) // "," // &
            int64_str(row%factorizations) // "," // int_str(row%code) // "," // &
            real_text(row%difference) // "," // real_text(row%tolerance) // "," // &
            real_text(row%compile_seconds)
    end function row_line

    !> Write a bench CSV file: the header and the rows.
    subroutine write_rows(path, rows)
        character(len=*), intent(in) :: path
        type(row_t), intent(in) :: rows(:)
        integer :: unit, i
        open (newunit=unit, file=path, status="replace", action="write")
        write (unit, '(a)') csv_header
        do i = 1, size(rows)
            write (unit, '(a)') row_line(rows(i))
        end do
        close (unit)
    end subroutine write_rows

    !> Parse a CSV line of the bench into a row; `ok` false unless it has 23 valid fields.
    subroutine parse_row(line, row, ok)
        character(len=*), intent(in) :: line
        type(row_t), intent(out) :: row
        logical, intent(out) :: ok
        character(len=:), allocatable :: text
        integer :: ios(20)
        ok = len(split_field(line, 23, ",")) > 0 .and. len(split_field(line, 24, ",")) == 0
        if (.not. ok) return
        row%system = split_field(line, 1, ",")
        row%method = split_field(line, 2, ",")
        row%precision = split_field(line, 3, ",")
        text = split_field(line, 4, ",")
        read (text, *, iostat=ios(1)) row%order_m
        text = split_field(line, 5, ",")
        read (text, *, iostat=ios(2)) row%order_n
        text = split_field(line, 6, ",")
        read (text, *, iostat=ios(3)) row%gauss_points
        text = split_field(line, 7, ",")
        read (text, *, iostat=ios(4)) row%order
        text = split_field(line, 8, ",")
        read (text, *, iostat=ios(5)) row%h
        text = split_field(line, 9, ",")
        read (text, *, iostat=ios(6)) row%steps
        text = split_field(line, 10, ",")
        read (text, *, iostat=ios(7)) row%error
        text = split_field(line, 11, ",")
        read (text, *, iostat=ios(8)) row%energy_error
        text = split_field(line, 12, ",")
        read (text, *, iostat=ios(9)) row%constraint_residual
        text = split_field(line, 13, ",")
        read (text, *, iostat=ios(10)) row%seconds
        text = split_field(line, 15, ",")
        read (text, *, iostat=ios(11)) row%newton_iterations
        text = split_field(line, 16, ",")
        read (text, *, iostat=ios(12)) row%residuals
        text = split_field(line, 17, ",")
        read (text, *, iostat=ios(13)) row%gradients
        text = split_field(line, 18, ",")
        read (text, *, iostat=ios(14)) row%hessians
        text = split_field(line, 19, ",")
        read (text, *, iostat=ios(15)) row%factorizations
        text = split_field(line, 20, ",")
        read (text, *, iostat=ios(16)) row%code
        text = split_field(line, 21, ",")
        read (text, *, iostat=ios(17)) row%difference
        text = split_field(line, 22, ",")
        read (text, *, iostat=ios(18)) row%tolerance
        text = split_field(line, 23, ",")
        read (text, *, iostat=ios(19)) row%compile_seconds
        ios(20) = 0
        ok = all(ios == 0)
    end subroutine parse_row

    !> Field k of a CSV line read as a number (integer or real(wp)); ios /= 0 when
    !! it is not one.
    subroutine read_field(line, k, value, ios)
        character(len=*), intent(in) :: line
        integer, intent(in) :: k
        class(*), intent(out) :: value
        integer, intent(out) :: ios
        character(len=:), allocatable :: text
        text = split_field(line, k, ",")
        ios = 1
        select type (value)
        type is (integer)
            read (text, *, iostat=ios) value
        type is (real(wp))
            read (text, *, iostat=ios) value
        end select
    end subroutine read_field

    !> Number of digits before the exponent of a number in scientific notation.
    pure integer function mantissa_digits(text)
        character(len=*), intent(in) :: text
        integer :: i
        mantissa_digits = 0
        do i = 1, len(text)
            if (scan(text(i:i), "eEdD") > 0) exit
            if (scan(text(i:i), "0123456789") > 0) mantissa_digits = mantissa_digits + 1
        end do
    end function mantissa_digits

    !> A fresh, empty scratch directory `name`; its path.
    function fresh_dir(name) result(dir)
        character(len=*), intent(in) :: name
        character(len=:), allocatable :: dir
        type(command_result_t) :: result
        dir = scratch_path(name)
        call run_shell("rm -rf " // shell_quote(dir) // " && mkdir -p " // shell_quote(dir), &
                       result)
    end function fresh_dir

    !> `holosym bench --summarize DIR`.
    subroutine summarize(error, dir, result)
        type(test_error_t), allocatable, intent(inout) :: error
        character(len=*), intent(in) :: dir
        type(command_result_t), intent(out) :: result
        call run_holosym(words("bench", "--summarize", dir), result)
        call check(error, len(result%failure) == 0, result%failure)
    end subroutine summarize

    !> The summary line of a target and system in a given precision section, or "".
    function summary_line(lines, section, target, system) result(line)
        type(text_line_t), intent(in) :: lines(:)
        character(len=*), intent(in) :: section, target, system
        character(len=:), allocatable :: line
        integer :: i
        logical :: inside
        line = ""
        inside = .false.
        do i = 1, size(lines)
            if (index(lines(i)%text, "## ") == 1) inside = lines(i)%text == "## " // section
            if (inside .and. index(lines(i)%text, "| " // target // " | " // system // " |") &
                == 1) line = lines(i)%text
        end do
    end function summary_line

    !> Cell k (1-based) of a Markdown table row "| cell 1 | cell 2 | ... |", trimmed.
    function cell(line, k) result(text)
        character(len=*), intent(in) :: line
        integer, intent(in) :: k
        character(len=:), allocatable :: text
        text = trim(adjustl(split_field(line, k + 1, "|")))
    end function cell

    !> How many of the lines start with `text`.
    integer function starting(lines, text)
        type(text_line_t), intent(in) :: lines(:)
        character(len=*), intent(in) :: text
        integer :: i
        starting = 0
        do i = 1, size(lines)
            if (index(lines(i)%text, text) == 1) starting = starting + 1
        end do
    end function starting

    !> Whether one of the lines is `text`.
    logical function has_line(lines, text)
        type(text_line_t), intent(in) :: lines(:)
        character(len=*), intent(in) :: text
        integer :: i
        has_line = .false.
        do i = 1, size(lines)
            if (lines(i)%text == text) has_line = .true.
        end do
    end function has_line

    !> Whether two line lists are equal.
    logical function same_lines(a, b)
        type(text_line_t), intent(in) :: a(:), b(:)
        integer :: i
        same_lines = size(a) == size(b)
        if (.not. same_lines) return
        do i = 1, size(a)
            if (a(i)%text /= b(i)%text) then
                same_lines = .false.
                return
            end if
        end do
    end function same_lines

    ! ------------------------------------------------------------------ tests

    !> The bench reads its CSV files to the last bit: a row whose error is exactly the target
    !! 1e-10 meets it and a cheaper one a single unit above does not; counters beyond the
    !! default integer range come back exactly (per-step table). The files a run writes
    !! carry 36 significant digits (see command_tiny_sweep_end_to_end).
    subroutine test_csv_exact(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(row_t) :: rows(2), steps(2)
        type(command_result_t) :: result
        character(len=:), allocatable :: dir, line, precision
        real(wp), parameter :: target = 1.0e-10_wp
        integer :: i, found
        character(len=16) :: expected

        dir = fresh_dir("bench_exact")
        precision = trim(merge("real64 ", "real128", wp_is_double))
        rows(1) = make_row("pendulum", "holosym", precision, 5, 0.5_wp, target, &
                           2.0e-3_real64, HOLOSYM_SUCCESS)
        rows(2) = make_row("pendulum", "holosym", precision, 6, 1.0_wp, &
                           nearest(target, 2.0_wp), 1.0e-3_real64, HOLOSYM_SUCCESS)
        steps(1) = make_row("pendulum", "variant-0", precision, 2, 0.125_wp, 1.0_wp, &
                            0.8_real64, HOLOSYM_SUCCESS)
        steps(2) = make_row("pendulum", "variant-9", precision, 2, 0.125_wp, 1.0_wp, &
                            0.1_real64, HOLOSYM_SUCCESS)
        steps(2)%newton_iterations = 5000000000_int64
        steps(2)%factorizations = 3000000000_int64
        steps(2)%gradients = 4567_int64
        call write_rows(dir // "/" // merge("bench64.csv", "bench.csv  ", wp_is_double), rows)
        call write_rows(dir // "/" // merge("steps64.csv", "steps.csv  ", wp_is_double), steps)
        call summarize(error, dir, result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "--summarize exits " // &
            int_str(result%exit_code))
        line = summary_line(result%out, trim(precision), "1.0e-10", "pendulum")
        call check(error, cell(line, 3) == "(5,4,6) h=0.5000", "the error equal to the " // &
            "target meets it; one unit above does not: " // line)
        found = 0
        do i = 1, size(result%out)
            if (index(result%out(i)%text, "| (2,1,3) " // precision // " |") /= 1) cycle
            found = found + 1
            if (found /= 2) cycle
            associate (text => result%out(i)%text)
                write (expected, '(f10.1)') 5000000000.0_real64 / steps(2)%steps
                call check(error, cell(text, 5) == trim(adjustl(expected)), &
                    "Newton iterations per step: " // text)
                write (expected, '(f10.1)') 3000000000.0_real64 / steps(2)%steps
                call check(error, cell(text, 6) == trim(adjustl(expected)), "LU per step: " // &
                    text)
                write (expected, '(f10.1)') 4567.0_real64 / steps(2)%steps
                call check(error, cell(text, 7) == trim(adjustl(expected)), &
                    "gradients per step: " // text)
            end associate
        end do
        call check(error, found == 2, int_str(found) // " per-step lines, expected 2")
    end subroutine test_csv_exact

    !> Malformed files fail `--summarize` (exit 1) with a message naming the file, line and
    !! field, and no summary is written; a well-formed file and a missing optional one do
    !! not fail.
    subroutine test_csv_malformed(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: good_row = "pendulum,holosym,real128,2,1,3,4," // &
            "1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2,1.25E-4,400,500,600,70,80,0,0,0,0"
        character(len=:), allocatable :: dir, path
        type(command_result_t) :: result
        type(text_line_t), allocatable :: page(:)
        integer :: ios

        dir = fresh_dir("bench_malformed")
        path = dir // "/bench.csv"
        call expect_failure([character(len=1000) :: "system,method", good_row], &
            "header", [character(len=24) :: "line 1", "header"])
        call expect_failure([character(len=1000) :: csv_header, good_row, &
            "pendulum,holosym,real128,2,1,3"], "too few fields", &
            [character(len=24) :: "line 3", "23"])
        call expect_failure([character(len=1000) :: csv_header, good_row // ",7"], &
            "too many fields", [character(len=24) :: "line 2", "23"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,oops,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "error not a number", &
            [character(len=24) :: "line 2", "error", "oops"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,x,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "N not a number", &
            [character(len=24) :: "line 2", "field N"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,variant-12,real128,2,1,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "unknown option set", &
            [character(len=24) :: "line 2", "variant-12"])
        ! Values out of their ranges: NaN, Inf, beyond the exponent range, negative seconds
        ! or step counts, a zero step, an unknown status code.
        call expect_failure([character(len=1000) :: csv_header, good_row, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,NaN,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "NaN error", &
            [character(len=24) :: "line 3", "field error", "NaN"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,Inf,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "Inf h", [character(len=24) :: "line 2", "field h"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,1.0E5000,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "error 1e5000", &
            [character(len=24) :: "line 2", "field error", "1.0E5000"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,-1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "negative seconds", &
            [character(len=24) :: "line 2", "field seconds"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,-80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "negative steps", &
            [character(len=24) :: "line 2", "field steps"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,0,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "zero h", [character(len=24) :: "line 2", "field h"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,-400,500,600,70,80,0,0,0,0"], "negative iterations", &
            [character(len=24) :: "line 2", "newton_iterations"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,99,0,0,0"], "unknown status", &
            [character(len=24) :: "line 2", "field status", "99"])
        ! The fields of heyoka's runs: the tolerance and the compile time.
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,heyoka,real128,0,0,0,20,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,0,0,0,0,0,0,0,NaN,0.5"], "NaN tolerance", &
            [character(len=24) :: "line 2", "field tolerance", "NaN"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,heyoka,real128,0,0,0,20,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,0,0,0,0,0,0,0,2,0.5"], "tolerance 2", &
            [character(len=24) :: "line 2", "field tolerance", "[0, 1)"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,heyoka,real128,0,0,0,20,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,0,0,0,0,0,0,0,1.0E-20,-0.5"], "negative compile seconds", &
            [character(len=24) :: "line 2", "field compile_seconds"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,heyoka,real128,0,0,0,20,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,0,0,0,0,0,0,0,1.0E-20,1e13"], "compile seconds 1e13", &
            [character(len=24) :: "line 2", "field compile_seconds", "1e12"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real256,2,1,3,4,1.25E-1,80,1.0E-9,1.0E-10,1.0E-33,1.0E-2," // &
            "1.25E-4,400,500,600,70,80,0,0,0,0"], "unknown precision", &
            [character(len=24) :: "line 2", "precision", "real256"])
        call expect_failure([character(len=1000) :: csv_header, &
            "pendulum,holosym,real128,2,1,3,4,1.25E-1,80,1.0E-9" // achar(0) // ",1.0E-10," // &
            "1.0E-33,1.0E-2,1.25E-4,400,500,600,70,80,0,0,0,0"], "a NUL byte", &
            [character(len=24) :: "line 2", "not text"])

        ! The well-formed file; bench64.csv, steps.csv and steps64.csv are missing and optional.
        call write_lines(path, [character(len=1000) :: csv_header, good_row])
        call summarize(error, dir, result)
        call check(error, result%exit_code == 0 .and. size(result%out) > 0, &
            "the well-formed file is summarized")
        call check(error, file_exists(dir // "/summary.md"), "summary.md written")
        if (allocated(error)) return

        ! The scaling and long-run files of the same directory are read as strictly.
        call write_lines(dir // "/scaling.csv", [character(len=100) :: &
            "precision,path,links,n,m,steps,seconds_per_step,max_rss_kb,status", &
            "real128,reduced,4,8,4,64,NaN,5000,0"])
        call summarize(error, dir, result)
        call check(error, result%exit_code == exit_failure .and. any_line(result, &
            "scaling.csv: line 2: field seconds_per_step is not a finite number: 'NaN'"), &
            "NaN seconds in scaling.csv: exit " // int_str(result%exit_code))
        call write_lines(dir // "/scaling.csv", [character(len=100) :: &
            "precision,path,links,n,m,steps,seconds_per_step,max_rss_kb,status", &
            "real128,reduced,4,8,4,64,1.0E-3,5000,0"])
        call write_lines(dir // "/long.csv", [character(len=160) :: &
            "system,method,precision,span,config,tolerance,steps,error,max_phi,max_hidden," &
            // "energy_error,seconds,compile_seconds,status", "planar,holosym,real128,20," // &
            "(6 5 7) h=0.5,0,-40,1.0E-21,1.0E-33,1.0E-33,1.0E-30,0.1,0,0"])
        call summarize(error, dir, result)
        call check(error, result%exit_code == exit_failure .and. any_line(result, &
            "long.csv: line 2: field steps is not >= 0: '-40'"), &
            "negative steps in long.csv: exit " // int_str(result%exit_code))
        call run_holosym(words("bench", "--long-section", dir), result)
        call check(error, result%exit_code == exit_failure .and. any_line(result, &
            "long.csv: line 2: field steps is not >= 0: '-40'"), &
            "--long-section refuses the malformed long.csv: exit " // int_str(result%exit_code))
        ! T spelled two ways (as holosym and heyoka write it) is one case.
        call write_lines(dir // "/long.csv", [character(len=160) :: &
            "system,method,precision,span,config,tolerance,steps,error,max_phi,max_hidden," &
            // "energy_error,seconds,compile_seconds,status", "planar,holosym,real128,20," // &
            "(6 5 7) h=0.5,0,40,1.0E-21,1.0E-33,1.0E-33,1.0E-30,0.1,0,0", &
            "planar,holosym-accuracy,real128,20,(8 7 9) h=0.4,1.0E-20,50,4.0E-21,1.0E-29," // &
            "1.0E-29,1.0E-29,0.08,0.02,0", &
            "planar,heyoka,real128,2.00000E+0001,order 30,1.0E-28,300,5.0E-22,1.0E-25," // &
            "1.0E-25,1.0E-26,0.3,1.5,0"])
        call summarize(error, dir, result)
        call check(error, result%exit_code == 0, "well-formed scaling.csv and long.csv: " // &
            "exit " // int_str(result%exit_code))
        call read_lines(dir // "/performance.md", page, ios)
        call check(error, ios == 0, "performance.md written")
        if (allocated(error)) return
        call check(error, has_line(page, "| planar | 2.00E+01 | 1.00E-20 | (6 5 7) h=0.5 | " // &
            "1.00E-01 | 1.00E-21 | 1.00E-33 | 1.00E-30 | tol 1.00E-28, order 30 | 3.00E-01 | " // &
            "5.00E-22 | 1.00E-25 | 1.00E-26 | 3.00 |"), "the long runs' row against heyoka")
        call check(error, has_line(page, "| planar | 2.00E+01 | 1.00E-20 | (8 7 9) h=0.4 | " // &
            "8.00E-02 | 4.00E-21 | 1.00E-29 | 1.00E-29 | 2.00E-02 | 3.00E-01 | 3.75 |"), &
            "the row through --accuracy against heyoka")

    contains

        logical function any_line(outcome, text)
            type(command_result_t), intent(in) :: outcome
            character(len=*), intent(in) :: text
            integer :: k
            any_line = .false.
            do k = 1, size(outcome%err)
                if (index(outcome%err(k)%text, text) > 0) any_line = .true.
            end do
        end function any_line

        subroutine expect_failure(lines, what, fragments)
            character(len=*), intent(in) :: lines(:)
            character(len=*), intent(in) :: what
            character(len=*), intent(in) :: fragments(:)
            integer :: k
            call run_shell("rm -f " // shell_quote(dir // "/summary.md"), result)
            call write_lines(path, lines)
            call summarize(error, dir, result)
            call check(error, result%exit_code == exit_failure, what // ": exit " // &
                int_str(result%exit_code) // ", expected 1")
            call check(error, size(result%out) == 0 .and. &
                .not. file_exists(dir // "/summary.md"), what // ": no summary")
            call check(error, size(result%err) == 1, what // ": one message")
            if (allocated(error)) return
            associate (message => result%err(1)%text)
                call check(error, index(message, "holosym bench: " // path // ": ") == 1, &
                    what // ": names the file: " // message)
                do k = 1, size(fragments)
                    call check(error, index(message, trim(fragments(k))) > 0, what // &
                        ": message mentions '" // trim(fragments(k)) // "': " // message)
                end do
            end associate
        end subroutine expect_failure

    end subroutine test_csv_malformed

    !> Per target, the summary shows the cheapest successful run below it (not a failed
    !! one, not the plain path, not a NaN error), the cheapest RATTLE run, the cheapest
    !! heyoka run (from heyoka.csv, with its compile time and whole-run residuals) and the
    !! ratios RATTLE / holosym and heyoka / holosym; real128 shows 1e-10 .. 1e-30, real64
    !! 1e-6 .. 1e-14.
    subroutine test_summary_cheapest(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(row_t), allocatable :: rows(:)
        type(row_t) :: taylor
        type(command_result_t) :: result
        character(len=:), allocatable :: line, dir
        real(real64), parameter :: best_seconds = 4.0e-3_real64, rattle_seconds = 4.0e-2_real64

        dir = fresh_dir("bench_cheapest")
        rows = [ &
            make_row("pendulum", "holosym", "real128", 5, 0.5_wp, 5.0e-11_wp, 1.0e-2_real64, 0), &
            make_row("pendulum", "holosym", "real128", 6, 1.0_wp, 1.0e-12_wp, best_seconds, 0), &
            make_row("pendulum", "holosym", "real128", 7, 1.0_wp, 1.0e-11_wp, 1.0e-3_real64, &
                     HOLOSYM_NEWTON_DIVERGED), &
            make_row("pendulum", "holosym-plain", "real128", 7, 1.0_wp, 1.0e-12_wp, &
                     5.0e-4_real64, 0), &
            make_row("pendulum", "holosym", "real128", 8, 1.0_wp, 1.0e-3_wp, 1.0e-4_real64, 0), &
            make_row("pendulum", "holosym", "real128", 3, 1.0_wp, 2.0e-10_wp, 2.0e-4_real64, 0), &
            make_row("pendulum", "rattle-suzuki", "real128", 0, 0.25_wp, 1.0e-11_wp, &
                     rattle_seconds, 0), &
            make_row("pendulum", "rattle-triple-jump", "real128", 0, 0.125_wp, 1.0e-13_wp, &
                     8.0e-2_real64, 0)]
        call write_rows(dir // "/bench.csv", rows)
        taylor = make_row("pendulum", "heyoka", "real128", 0, 0.05_wp, 1.0e-11_wp, &
                          heyoka_seconds, 0)
        taylor%order = 13
        taylor%tolerance = 1.0e-12_wp
        taylor%compile_seconds = 0.25_wp
        taylor%constraint_residual = 3.0e-12_wp
        taylor%energy_error = 2.0e-12_wp
        call write_rows(dir // "/heyoka.csv", [taylor])
        call summarize(error, dir, result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "--summarize exits " // &
            int_str(result%exit_code))

        line = summary_line(result%out, "real128", "1.0e-10", "pendulum")
        call check(error, len(line) > 0, "a real128 line for 1e-10, pendulum")
        if (allocated(error)) return
        call check(error, cell(line, 3) == "(6,5,7) h=1.000", "cheapest holosym: " // line)
        call check(error, cell(line, 4) == "4.00E-03", "its seconds: " // cell(line, 4))
        call check(error, cell(line, 5) == "suzuki p=0 h=0.2500", "cheapest RATTLE: " // line)
        call check(error, cell(line, 7) == ratio_text(rattle_seconds / best_seconds), &
            "x RATTLE " // cell(line, 7))
        call check(error, cell(line, 8) == "tol 1.0E-12, order 13", "heyoka run: " // line)
        call check(error, cell(line, 9) == "1.60E-03", "heyoka's time: " // cell(line, 9))
        call check(error, cell(line, 10) == ratio_text(heyoka_seconds / best_seconds), &
            "x heyoka " // cell(line, 10))
        call check(error, cell(line, 11) == "2.50E-01", "compile time: " // cell(line, 11))
        call check(error, cell(line, 12) == "3.0E-12" .and. cell(line, 13) == "2.0E-12", &
            "heyoka's residual and energy error: " // line)

        ! 1e-14: nothing reaches it.
        line = summary_line(result%out, "real128", "1.0e-14", "pendulum")
        call check(error, cell(line, 3) == "—" .and. cell(line, 5) == "—" .and. &
            cell(line, 8) == "—", "1e-14: none: " // line)
        ! 1e-30 is a real128 target, 1e-6 is not.
        call check(error, len(summary_line(result%out, "real128", "1.0e-30", &
            "pendulum")) > 0, "a real128 line for 1e-30")
        call check(error, len(summary_line(result%out, "real128", "1.0e-06", &
            "pendulum")) == 0, "no real128 line for 1e-6")
        ! Systems without rows and precisions without rows are left out.
        call check(error, len(summary_line(result%out, "real128", "1.0e-10", &
            "linkage")) == 0, "no linkage lines")
        call check(error, .not. has_line(result%out, "## real64"), "no real64 section")
        if (allocated(error)) return

        ! A real64 row (bench64.csv) adds its section, with the targets 1e-6 .. 1e-14.
        call write_rows(dir // "/bench64.csv", [make_row("pendulum", "holosym", "real64", 4, &
                        0.5_wp, 1.0e-11_wp, 1.0e-4_real64, 0)])
        call summarize(error, dir, result)
        line = summary_line(result%out, "real64", "1.0e-10", "pendulum")
        call check(error, cell(line, 3) == "(4,3,5) h=0.5000", "real64 line: " // line)
        line = summary_line(result%out, "real64", "1.0e-06", "pendulum")
        call check(error, cell(line, 3) == "(4,3,5) h=0.5000", "real64 1e-6: " // line)
        call check(error, cell(line, 8) == "—", "no real64 heyoka row: " // line)
        line = summary_line(result%out, "real128", "1.0e-10", "pendulum")
        call check(error, cell(line, 3) == "(6,5,7) h=1.000", "real128 line unchanged: " // line)
        call check(error, file_exists(dir // "/performance.md"), "performance.md written")
    end subroutine test_summary_cheapest

    !> The runs through --accuracy (method holosym-accuracy: tolerance the request,
    !! compile_seconds the pilot) have their own table and verdict: the plan, the error,
    !! pilot and run seconds, heyoka's cheapest run reaching the target and the ratios to
    !! the run and to pilot and run together; a refused request says so; they never pass
    !! for the cheapest run of the sweeps.
    subroutine test_summary_accuracy(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(row_t) :: rows(3), taylor
        type(command_result_t) :: result
        type(text_line_t), allocatable :: page(:)
        character(len=:), allocatable :: line, dir, section
        real(real64), parameter :: pilot = 6.0e-3_real64, run = 1.0e-4_real64
        integer :: ios, i
        logical :: found
        dir = fresh_dir("bench_accuracy")
        rows(1) = make_row("pendulum", "holosym", "real128", 6, 1.0_wp, 1.0e-12_wp, &
                           4.0e-3_real64, 0)
        ! Cheaper than the sweep's run and below the target: still not the sweep's best.
        rows(2) = make_row("pendulum", "holosym-accuracy", "real128", 6, 0.5_wp, 5.0e-11_wp, &
                           run, 0)
        rows(2)%tolerance = 1.0e-10_wp
        rows(2)%compile_seconds = real(pilot, wp)
        rows(3) = make_row("pendulum", "holosym-accuracy", "real128", 8, 10.0_wp, 0.0_wp, &
                           0.0_real64, HOLOSYM_INVALID_ARGUMENT)
        rows(3)%tolerance = 1.0e-30_wp
        call write_rows(dir // "/bench.csv", rows)
        taylor = make_row("pendulum", "heyoka", "real128", 0, 0.05_wp, 1.0e-11_wp, &
                          heyoka_seconds, 0)
        taylor%order = 13
        taylor%tolerance = 1.0e-12_wp
        call write_rows(dir // "/heyoka.csv", [taylor])
        call summarize(error, dir, result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "--summarize exits " // &
            int_str(result%exit_code))
        line = summary_line(result%out, "real128", "1.0e-10", "pendulum")
        call check(error, cell(line, 3) == "(6,5,7) h=1.000", "the sweep's cheapest: " // line)
        section = "real128 through --accuracy"
        line = summary_line(result%out, section, "1.0e-10", "pendulum")
        call check(error, len(line) > 0, "an --accuracy line for 1e-10")
        if (allocated(error)) return
        call check(error, cell(line, 3) == "(6,5,7) h=0.5000, 20 steps", "plan: " // line)
        call check(error, cell(line, 4) == "5.0E-11", "error: " // line)
        call check(error, cell(line, 5) == "6.00E-03" .and. cell(line, 6) == "1.00E-04", &
            "pilot and run seconds: " // line)
        call check(error, cell(line, 7) == "1.60E-03", "heyoka's time: " // line)
        call check(error, cell(line, 8) == ratio_text(heyoka_seconds / run), &
            "x heyoka (run): " // line)
        call check(error, cell(line, 9) == ratio_text(heyoka_seconds / (run + pilot)), &
            "x heyoka (pilot + run): " // line)
        line = summary_line(result%out, section, "1.0e-30", "pendulum")
        call check(error, index(cell(line, 3), "refused: " // &
            status_code_name(HOLOSYM_INVALID_ARGUMENT)) == 1 .and. cell(line, 8) == "—", &
            "a refused request: " // line)
        line = summary_line(result%out, section, "1.0e-14", "pendulum")
        call check(error, len(line) == 0, "no line without a run: " // line)
        if (allocated(error)) return
        ! The verdict: heyoka reaches 1e-10 only; 1.6e-3 / 6.1e-3 < 2; error 0.5 x request.
        call read_lines(dir // "/performance.md", page, ios)
        call check(error, ios == 0, "performance.md read")
        if (allocated(error)) return
        found = .false.
        do i = 1, size(page)
            if (index(page(i)%text, "- real128 through `--accuracy`") /= 1) cycle
            found = .true.
            call check(error, index(page(i)%text, "met at 0 of 1 pairs; smallest ratio " // &
                ratio_text(heyoka_seconds / (run + pilot))) > 0 .and. &
                index(page(i)%text, "at most " // ratio_text(0.5_real64) // " times") > 0, &
                "verdict: " // page(i)%text)
        end do
        call check(error, found, "a verdict through --accuracy in performance.md")
    end subroutine test_summary_accuracy

    !> The per-step table: seconds per step and the ratio to the plain path (option set 0)
    !! of the same configuration; rows that are not an option set are left out.
    subroutine test_summary_per_step(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(row_t) :: steps(3)
        type(command_result_t) :: result
        character(len=:), allocatable :: dir
        integer :: i, found
        character(len=16) :: expected
        dir = fresh_dir("bench_per_step")
        steps(1) = make_row("pendulum", "variant-0", "real128", 2, 0.125_wp, 1.0_wp, &
                            0.8_real64, 0)
        steps(2) = make_row("pendulum", "holosym", "real128", 2, 0.125_wp, 1.0_wp, &
                            0.1_real64, 0)
        steps(3) = make_row("pendulum", "variant-9", "real128", 2, 0.125_wp, 1.0_wp, &
                            0.1_real64, 0)
        steps%newton_iterations = [480_int64, 0_int64, 400_int64]
        call write_rows(dir // "/steps.csv", steps)
        call summarize(error, dir, result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "--summarize exits " // &
            int_str(result%exit_code))
        found = 0
        do i = 1, size(result%out)
            if (index(result%out(i)%text, "| (2,1,3) real128 |") /= 1) cycle
            found = found + 1
            if (found == 2) then
                call check(error, cell(result%out(i)%text, 4) == ratio_text(0.8_real64 / &
                    0.1_real64), "x plain of option set 9: " // result%out(i)%text)
                call check(error, cell(result%out(i)%text, 5) == ratio_text(400.0_real64 / &
                    steps(3)%steps), &
                    "Newton iterations per step: " // result%out(i)%text)
            end if
        end do
        call check(error, found == 2, int_str(found) // " per-step lines, expected 2 " // &
            "(the holosym row left out)")
    end subroutine test_summary_per_step

    !> A tiny real sweep: holosym M = 1 and plain RATTLE on the pendulum with a 0.01 s
    !! budget. The CSV rows are consistent (steps h = T, errors finite and shrinking with h,
    !! 36 significant digits), the reference file is well-formed, the summary goes to
    !! standard output and summary.md, `--summarize` rebuilds the same file, and a directory
    !! without bench files is an error.
    subroutine test_command_end_to_end(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result, again
        type(text_line_t), allocatable :: csv(:), refs(:), summary(:), rebuilt(:)
        type(row_t), allocatable :: rows(:)
        type(row_t) :: row
        character(len=:), allocatable :: dir, csv_name, args(:)
        integer :: i, ios, first_holosym, last_holosym, accuracy_rows
        logical :: ok

        dir = fresh_dir("bench_sweep")
        allocate (character(len=max(len(dir), 13)) :: args(12))
        args(1:2) = ["bench", "--out"]
        args(3) = dir
        args(4:8) = [character(len=13) :: "--systems", "pendulum", "--Mmax", "1", "--order"]
        args(9:12) = [character(len=13) :: "2", "--budget", "0.01", "--no-per-step"]
        call run_holosym(args, result)
        call check(error, len(result%failure) == 0, result%failure)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "bench exits 0, got " // &
            int_str(result%exit_code))
        if (allocated(error)) return
        call check_progress(error, result%err)
        if (allocated(error)) return

        csv_name = dir // "/" // trim(merge("bench64.csv", "bench.csv  ", wp_is_double))
        call read_lines(csv_name, csv, ios)
        call check(error, ios == 0 .and. size(csv) >= 5, "read " // csv_name // ": " // &
            int_str(size(csv)) // " lines")
        if (allocated(error)) return
        call check(error, csv(1)%text == csv_header, "the CSV header")
        allocate (rows(0))
        do i = 2, size(csv)
            call parse_row(csv(i)%text, row, ok)
            call check(error, ok, "row " // int_str(i - 1) // " has 23 valid fields: " // &
                csv(i)%text)
            call check(error, mantissa_digits(split_field(csv(i)%text, 8, ",")) >= 33 .and. &
                mantissa_digits(split_field(csv(i)%text, 10, ",")) >= 33, "row " // &
                int_str(i - 1) // ": h and error with 36 significant digits")
            if (allocated(error)) return
            rows = [rows, row]
        end do
        first_holosym = 0
        last_holosym = 0
        accuracy_rows = 0
        do i = 1, size(rows)
            call check(error, rows(i)%system == "pendulum", "system of row " // int_str(i))
            call check(error, rows(i)%method == "holosym" .or. &
                rows(i)%method == "holosym-accuracy" .or. &
                rows(i)%method == "rattle-triple-jump", "method of row " // rows(i)%method)
            if (rows(i)%method == "holosym-accuracy") then
                call check_accuracy_row(error, rows(i))
                accuracy_rows = accuracy_rows + 1
                cycle
            end if
            call check_close(error, rows(i)%steps * rows(i)%h, pendulum_span, &
                64 * epsilon(1.0_wp), 0.0_wp, "steps h = T in row " // int_str(i))
            if (rows(i)%code == HOLOSYM_SUCCESS) call check(error, rows(i)%error > 0 .and. &
                rows(i)%error <= huge(1.0_wp), "row " // int_str(i) // ": finite error " // &
                real_str(rows(i)%error))
            call check(error, rows(i)%newton_iterations > 0 .or. rows(i)%method /= "holosym" &
                .or. rows(i)%code /= HOLOSYM_SUCCESS, &
                "holosym rows count Newton iterations")
            if (rows(i)%method == "holosym" .and. rows(i)%gauss_points == 1 .and. &
                rows(i)%code == HOLOSYM_SUCCESS) then
                if (first_holosym == 0) first_holosym = i
                last_holosym = i
            end if
        end do
        if (allocated(error)) return
        call check(error, accuracy_rows == merge(3, 6, wp_is_double), int_str(accuracy_rows) // &
            " runs through --accuracy, one per target of the precision")
        call check(error, last_holosym > first_holosym, "at least two (1,0,1) runs")
        if (allocated(error)) return
        ! Order 2: the error falls with h (by about the square of the step ratio).
        call check(error, rows(last_holosym)%h < rows(first_holosym)%h .and. &
            rows(last_holosym)%error < rows(first_holosym)%error, "error falls with h: " // &
            real_str(rows(first_holosym)%error) // " at h = " // &
            real_str(rows(first_holosym)%h) // ", " // real_str(rows(last_holosym)%error) // &
            " at h = " // real_str(rows(last_holosym)%h))

        ! The reference file: 3 q and 3 p values and a comment with the reference step 1/16.
        call read_lines(dir // "/reference.csv", refs, ios)
        call check(error, count_prefix(refs, "pendulum,q,") == 3 .and. &
            count_prefix(refs, "pendulum,p,") == 3, "3 q and 3 p reference values")
        call check(error, count_prefix(refs, "# pendulum: M = 8, h = " // real_str(0.0625_wp) &
            // " and h/2") == 1, "reference comment names h = 1/16")

        ! The summary: on standard output and in summary.md, the same lines.
        call read_lines(dir // "/summary.md", summary, ios)
        call check(error, size(summary) > 10 .and. same_lines(summary, result%out), &
            "summary.md has the lines printed: " // int_str(size(summary)) // " and " // &
            int_str(size(result%out)))
        call check(error, len(summary_line(summary, trim(merge("real64 ", "real128", &
            wp_is_double)), "1.0e-10", "pendulum")) > 0, "a line for 1e-10, pendulum")
        if (allocated(error)) return

        ! --summarize rebuilds the same summary from the CSV files.
        call run_shell("rm -f " // shell_quote(dir // "/summary.md"), again)
        call summarize(error, dir, again)
        call check(error, again%exit_code == 0, "--summarize exits 0")
        call read_lines(dir // "/summary.md", rebuilt, ios)
        call check(error, ios == 0, "--summarize writes summary.md")
        call check(error, same_lines(rebuilt, summary) .and. same_lines(again%out, summary), &
            "--summarize: the same lines")

        ! A directory without bench files is an error, reported on standard error.
        dir = fresh_dir("bench_empty")
        call summarize(error, dir, again)
        call check(error, again%exit_code == exit_failure, &
            "--summarize of an empty directory exits 1")
        call check(error, size(again%err) > 0, "and says why")
        if (size(again%err) > 0) call check(error, index(again%err(1)%text, "no bench.csv") > 0, &
            "message: " // again%err(1)%text)

    contains

        !> A run through --accuracy: the request is a target of the precision; it reaches
        !! at most 10 times the request in whole steps to T, with a pilot, or it is refused
        !! as below the round-off floor (the real64 build's 1e-14).
        subroutine check_accuracy_row(error, row)
            type(test_error_t), allocatable, intent(inout) :: error
            type(row_t), intent(in) :: row
            if (row%code /= HOLOSYM_SUCCESS) then
                call check(error, row%code == HOLOSYM_INVALID_ARGUMENT .and. wp_is_double .and. &
                    row%tolerance < 1.0e-13_wp, "--accuracy " // real_str(row%tolerance) // &
                    " refused with code " // int_str(row%code))
                return
            end if
            call check(error, row%error <= 10 * row%tolerance, "--accuracy " // &
                real_str(row%tolerance) // " reaches " // real_str(row%error))
            call check_close(error, row%steps * row%h, pendulum_span, 64 * epsilon(1.0_wp), &
                0.0_wp, "--accuracy: steps h = T")
            call check(error, row%compile_seconds > 0 .and. row%newton_iterations > 0, &
                "--accuracy " // real_str(row%tolerance) // ": pilot seconds and iterations")
        end subroutine check_accuracy_row

        pure integer function count_prefix(lines, prefix)
            type(text_line_t), intent(in) :: lines(:)
            character(len=*), intent(in) :: prefix
            integer :: k
            count_prefix = 0
            do k = 1, size(lines)
                if (index(lines(k)%text, prefix) == 1) count_prefix = count_prefix + 1
            end do
        end function count_prefix

    end subroutine test_command_end_to_end

    !> The progress lines of a bench run: the reference announced before it is computed;
    !! then every run as "bench: [k/N, E elapsed, ...] ...", k rising from 1 to N with one
    !! N, and a failed run with its status and reason (never "error 0 (failed)").
    subroutine check_progress(error, lines)
        type(test_error_t), allocatable, intent(inout) :: error
        type(text_line_t), intent(in) :: lines(:)
        integer :: i, k, total, last_k, last_total, runs, ios, slash, comma
        character(len=:), allocatable :: text
        call check(error, size(lines) > 0, "bench prints progress")
        if (allocated(error)) return
        call check(error, index(lines(1)%text, "bench: reference for pendulum: computing") &
            == 1, "first line announces the reference: " // lines(1)%text)
        if (allocated(error)) return
        last_k = 0
        last_total = -1
        runs = 0
        do i = 1, size(lines)
            text = lines(i)%text
            if (index(text, "bench: [") /= 1) cycle
            runs = runs + 1
            slash = index(text, "/")
            comma = index(text, ",")
            read (text(9:slash - 1), *, iostat=ios) k
            if (ios == 0) read (text(slash + 1:comma - 1), *, iostat=ios) total
            call check(error, ios == 0 .and. index(text, " elapsed, ") > 0 .and. &
                (index(text, " left] ") > 0 .or. index(text, "not known yet] ") > 0), &
                "progress line: " // text)
            if (allocated(error)) return
            call check(error, (last_total < 0 .or. total == last_total) .and. &
                (k == last_k .or. k == last_k + 1) .and. k <= total, &
                "k/N in order with one N: " // text)
            if (allocated(error)) return
            if (index(text, "failed") > 0) call check(error, index(text, ": failed: ") > 0 &
                .and. index(text, "error 0") == 0, "a failed run says why: " // text)
            if (allocated(error)) return
            last_k = k
            last_total = total
        end do
        call check(error, runs > 0 .and. last_k == last_total, "the last sweep is N of N")
    end subroutine check_progress

    !> `bench --scaling --quick`: one CSV line per (K, path), K = 1, 2, 4, 8 on the reduced
    !! step and K <= 4 on the general path, with sane sizes, times and memory; the
    !! performance page gets its scaling section; a bad --scaling-point is refused.
    subroutine test_scaling_quick(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: csv(:), page(:)
        character(len=:), allocatable :: dir, name, line
        integer :: i, ios, links, n, m, steps, status, reduced, general
        real(wp) :: seconds, memory
        dir = fresh_dir("bench_scaling")
        call run_holosym(words("bench", "--scaling", "--quick", "--out", dir), result)
        call check(error, len(result%failure) == 0 .and. result%exit_code == 0, &
            "bench --scaling --quick exits 0, got " // int_str(result%exit_code))
        if (allocated(error)) return
        name = dir // "/" // trim(merge("scaling64.csv", "scaling.csv  ", wp_is_double))
        call read_lines(name, csv, ios)
        call check(error, ios == 0 .and. size(csv) == 8, "read " // name // ": " // &
            int_str(size(csv)) // " lines, expected 8")
        if (allocated(error)) return
        call check(error, csv(1)%text == "precision,path,links,n,m,steps,seconds_per_step," // &
            "max_rss_kb,status", "scaling header: " // csv(1)%text)
        reduced = 0
        general = 0
        do i = 2, size(csv)
            line = csv(i)%text
            call check(error, split_field(line, 1, ",") == trim(merge("real64 ", "real128", &
                wp_is_double)), "precision of " // line)
            if (split_field(line, 2, ",") == "reduced") reduced = reduced + 1
            if (split_field(line, 2, ",") == "general") general = general + 1
            call read_field(line, 3, links, ios)
            if (ios == 0) call read_field(line, 4, n, ios)
            if (ios == 0) call read_field(line, 5, m, ios)
            if (ios == 0) call read_field(line, 6, steps, ios)
            if (ios == 0) call read_field(line, 7, seconds, ios)
            if (ios == 0) call read_field(line, 8, memory, ios)
            if (ios == 0) call read_field(line, 9, status, ios)
            call check(error, ios == 0, "fields of " // line)
            if (allocated(error)) return
            call check(error, n == 2 * links .and. m == links, "n = 2K, m = K: " // line)
            call check(error, status == 0 .and. steps >= 1, "status 0, steps: " // line)
            call check(error, seconds > 0 .and. seconds < 1, "seconds per step: " // line)
            call check(error, memory > 1000 .and. memory < 1.0e7_wp, "peak kB: " // line)
            if (allocated(error)) return
        end do
        call check(error, reduced == 4 .and. general == 3, int_str(reduced) // " reduced, " // &
            int_str(general) // " general lines, expected 4 and 3")
        call read_lines(dir // "/performance.md", page, ios)
        call check(error, ios == 0 .and. &
            has_line(page, "## Scaling: a chain of K planar pendula"), &
            "performance.md has the scaling section")
        call run_holosym(words("bench", "--scaling-point", "0"), result)
        call check(error, result%exit_code /= 0, "--scaling-point 0 is refused")
    end subroutine test_scaling_quick

    !> `bench --long --quick` (holosym only, no heyoka): the reference file, and for each
    !! case and configuration the cheapest runs reaching 1e-20 and 1e-24, with the
    !! constraints at round-off over the whole run; the real64 build refuses --long.
    subroutine test_long_quick(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: csv(:), refs(:), page(:)
        character(len=:), allocatable :: dir, line
        integer :: i, ios, rows, planned, status
        real(wp) :: run_error, max_phi, energy_error, request
        dir = fresh_dir("bench_long")
        call run_holosym(words("bench", "--long", "--quick", "--out", dir), result)
        call check(error, len(result%failure) == 0, result%failure)
        if (wp_is_double) then
            call check(error, result%exit_code == exit_failure .and. &
                any_err(result, "real128"), "the real64 build refuses --long")
            return
        end if
        call check(error, result%exit_code == 0, "bench --long --quick exits 0, got " // &
            int_str(result%exit_code))
        if (allocated(error)) return
        call read_lines(dir // "/long.csv", csv, ios)
        call check(error, ios == 0 .and. size(csv) >= 5, "long.csv: " // int_str(size(csv)) // &
            " lines")
        if (allocated(error)) return
        call check(error, csv(1)%text == "system,method,precision,span,config,tolerance," // &
            "steps,error,max_phi,max_hidden,energy_error,seconds,compile_seconds,status", &
            "long header: " // csv(1)%text)
        rows = 0
        planned = 0
        do i = 2, size(csv)
            line = csv(i)%text
            call read_field(line, 6, request, ios)
            if (ios == 0) call read_field(line, 8, run_error, ios)
            if (ios == 0) call read_field(line, 9, max_phi, ios)
            if (ios == 0) call read_field(line, 11, energy_error, ios)
            if (ios == 0) call read_field(line, 14, status, ios)
            call check(error, ios == 0, "fields of " // line)
            if (allocated(error)) return
            if (split_field(line, 2, ",") == "holosym-accuracy") then
                ! Through init_for_accuracy: the request met within 10x, the constraints
                ! held at least to it.
                call check(error, status == 0 .and. run_error <= 10 * request .and. &
                    max_phi <= request, "through --accuracy: " // line)
                planned = planned + 1
                cycle
            end if
            call check(error, split_field(line, 2, ",") == "holosym", "method of " // line)
            call check(error, status == 0 .and. run_error <= 1.0e-20_wp, "error at T: " // line)
            call check(error, max_phi <= 1.0e-30_wp, "whole-run max |phi|: " // line)
            call check(error, energy_error < 1.0e-18_wp, "energy error: " // line)
            rows = rows + 1
        end do
        call check(error, rows >= 4, int_str(rows) // " holosym rows")
        call check(error, planned == 4, int_str(planned) // " rows through --accuracy " // &
            "(two cases, two targets)")
        call read_lines(dir // "/long_reference.csv", refs, ios)
        call check(error, ios == 0 .and. size(refs) > 4, "long_reference.csv written")
        call read_lines(dir // "/performance.md", page, ios)
        call check(error, ios == 0 .and. has_line(page, "## Long runs"), &
            "performance.md has the long-run section")
        ! Two cases by two targets, in the table of the sweeps and in that through --accuracy.
        call check(error, ios == 0 .and. has_line(page, "| system | T | target | plan | " // &
            "pilot + run s | error | max phi | energy error | pilot s | heyoka s | x |") .and. &
            starting(page, "| planar |") == 4 .and. starting(page, "| pendulum |") == 4, &
            "performance.md has the table through --accuracy, a row per case and target")
    contains
        logical function any_err(outcome, text)
            type(command_result_t), intent(in) :: outcome
            character(len=*), intent(in) :: text
            integer :: k
            any_err = .false.
            do k = 1, size(outcome%err)
                if (index(outcome%err(k)%text, text) > 0) any_err = .true.
            end do
        end function any_err
    end subroutine test_long_quick

end module test_bench
