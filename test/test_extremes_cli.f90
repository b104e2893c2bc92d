!> Tests of `holosym extremes`, run as an executable: the parts and sizes chosen by the
!! options show in the report, bad options are rejected with exit status 2 and a message
!! naming the option and the value, and the full quick report (all six parts) is written,
!! its fitted growth exponents consistent with the RMS table they are fitted to.
module test_extremes_cli
    use holosym_kinds, only: wp
    use holosym_status_codes, only: int_str, real_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, split_field
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, &
        any_line_contains
    implicit none
    private
    public :: extremes_cli_tests

    !> Section titles of the report, in the order of the parts.
    character(len=*), parameter :: sections(6) = [character(len=32) :: "## 1. Long run", &
        "## 2. Tiny steps", "## 3. High orders", "## 4. Large steps", "## 5. Stiff springs", &
        "## 6. Near-singular constraints"]

contains

    !> The tests of this suite.
    function extremes_cli_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("cli_options", cli_options), &
            new_test("cli_rejects_bad_options", cli_rejects), &
            new_test("cli_quick_report", cli_quick_report)]
    end function extremes_cli_tests

    !> Run `holosym extremes` with `line`; fail unless it ran and exited 0.
    subroutine extremes(error, line, result)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        character(len=*), intent(in) :: line            !! options
        type(command_result_t), intent(out) :: result   !! what it did
        call run_holosym("extremes " // line, result)
        call check(error, len(result%failure) == 0, result%failure)
        call check(error, result%exit_code == 0, "extremes " // line // ": exit " // &
            int_str(result%exit_code))
    end subroutine extremes

    !> Check that the report has exactly the sections of `parts` (1..6).
    subroutine check_sections(error, result, parts, what)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        type(command_result_t), intent(in) :: result  !! an extremes run
        integer, intent(in) :: parts(:)               !! parts that must appear
        character(len=*), intent(in) :: what          !! the options, for messages
        integer :: k
        do k = 1, size(sections)
            call check(error, any_line_contains(result%out, trim(sections(k))) .eqv. &
                any(parts == k), what // ": section '" // trim(sections(k)) // "' " // &
                trim(merge("missing   ", "unexpected", any(parts == k))))
        end do
    end subroutine check_sections

    !> Parts and sizes: --part lists (also inline, also "all"), --max-order and the help.
    subroutine cli_options(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        integer :: order_m
        call extremes(error, "--quick --part stiff,near-singular", result)
        call check_sections(error, result, [5, 6], "--part stiff,near-singular")
        call extremes(error, "--quick --part=near-singular", result)
        call check_sections(error, result, [6], "--part=near-singular")
        ! The quick sizes: 8 steps of the near-singular runs.
        call check(error, any_line_contains(result%out, "then 8 steps of h = 1/64"), &
            "quick near-singular sizes")
        call extremes(error, "--quick --part high --max-order 4", result)
        call check_sections(error, result, [3], "--part high")
        do order_m = 1, 5
            call check(error, any_line_contains(result%out, "| " // int_str(order_m) // " | " // &
                int_str(order_m + 1) // " | ") .eqv. order_m <= 4, "--max-order 4: row M = " // &
                int_str(order_m))
        end do
        call extremes(error, "--help", result)
        call check(error, any_line_contains(result%out, "Usage: holosym extremes"), "--help")
    end subroutine cli_options

    !> Missing, malformed and out-of-range values and unknown options or parts: exit 2 and a
    !! message naming the option and the value.
    subroutine cli_rejects(error)
        type(test_error_t), allocatable, intent(out) :: error
        call reject("--steps 0", [character(len=16) :: "--steps", "'0'"])
        call reject("--steps -5", [character(len=16) :: "--steps", "'-5'"])
        call reject("--steps 1e3", [character(len=16) :: "--steps", "'1e3'"])
        call reject("--steps 99999999999999999999", [character(len=24) :: "--steps", &
                    "must be in 1..2147483647", "'99999999999999999999'"])
        call reject("--steps", [character(len=16) :: "--steps", "a value"])
        call reject("--max-order 16", [character(len=16) :: "--max-order", "'16'"])
        call reject("--max-order 0", [character(len=16) :: "--max-order", "'0'"])
        call reject("--max-order x", [character(len=16) :: "--max-order", "'x'"])
        call reject("--part bogus", [character(len=16) :: "--part", "'bogus'"])
        call reject("--part long,", [character(len=16) :: "--part", "''"])
        call reject("--part", [character(len=16) :: "--part", "a value"])
        call reject("--frobnicate", [character(len=16) :: "--frobnicate"])

    contains

        subroutine reject(line, texts)
            character(len=*), intent(in) :: line
            character(len=*), intent(in) :: texts(:)
            type(command_result_t) :: result
            integer :: k
            if (allocated(error)) return
            call run_holosym("extremes " // line, result)
            call check(error, result%exit_code == 2 .and. size(result%err) == 2 .and. &
                size(result%out) == 0, "'" // line // "': exit " // int_str(result%exit_code))
            if (allocated(error)) return
            call check(error, result%err(2)%text == &
                "Run 'holosym extremes --help' for the options.", "'" // line // "': hint")
            do k = 1, size(texts)
                call check(error, index(result%err(1)%text, trim(texts(k))) > 0, &
                    "message for '" // line // "' should name " // trim(texts(k)) // ": " // &
                    result%err(1)%text)
            end do
        end subroutine reject

    end subroutine cli_rejects

    !> `extremes --quick --part all --steps 500`: all six sections; the long run did its
    !! 500 steps; the growth exponents printed are the least-squares slopes of the RMS
    !! table above them (blocks ending at step 16 or later, zero entries skipped).
    subroutine cli_quick_report(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        real(wp) :: points(32), compensated(32), naive(32), general(32), printed(3)
        integer :: i, rows, first, last, ios
        logical :: inside
        character(len=:), allocatable :: line, tail

        call extremes(error, "--quick --part all --steps 500", result)
        if (allocated(error)) return
        call check_sections(error, result, [1, 2, 3, 4, 5, 6], "--part all")
        call check(error, any_line_contains(result%out, "500 of 500 steps (t = ") .and. &
            any_line_contains(result%out, "| max relative energy error, first 500 steps |"), &
            "the long run did 500 steps, its early window all of them")
        call check(error, any_line_contains(result%out, "), status success, "), &
            "the long run succeeded")
        if (allocated(error)) return
        rows = 0
        inside = .false.
        printed = -1
        do i = 1, size(result%out)
            line = result%out(i)%text
            if (index(line, "| steps | RMS, compensated") == 1) inside = .true.
            if (inside .and. index(line, "| ") == 1 .and. index(line, "-") > 0 .and. &
                verify(line(3:3), "0123456789") == 0) then
                tail = split_field(split_field(line, 2, "|"), 1, "-")
                read (tail, *, iostat=ios) first
                tail = split_field(split_field(line, 2, "|"), 2, "-")
                read (tail, *, iostat=ios) last
                if (last >= 16) then
                    rows = rows + 1
                    points(rows) = (real(first, wp) + last) / 2
                    tail = split_field(line, 3, "|")
                    read (tail, *, iostat=ios) compensated(rows)
                    tail = split_field(line, 4, "|")
                    read (tail, *, iostat=ios) naive(rows)
                    tail = split_field(line, 5, "|")
                    read (tail, *, iostat=ios) general(rows)
                end if
            end if
            if (index(line, "Fitted growth exponent") == 1) then
                tail = line(index(line, "compensated ") + len("compensated "):)
                read (tail(:index(tail, ",") - 1), *, iostat=ios) printed(1)
                tail = line(index(line, "naive ") + len("naive "):)
                read (tail(:index(tail, ",") - 1), *, iostat=ios) printed(2)
                tail = line(index(line, "general path ") + len("general path "):)
                read (tail(:len(tail) - 1), *, iostat=ios) printed(3)
                exit
            end if
        end do
        call check(error, rows >= 3 .and. all(printed >= 0), "growth table and exponents " // &
            "found: " // int_str(rows) // " blocks")
        if (allocated(error)) return
        call check(error, abs(slope(points(:rows), compensated(:rows)) - printed(1)) <= &
            0.02_wp .and. abs(slope(points(:rows), naive(:rows)) - printed(2)) <= 0.02_wp &
            .and. abs(slope(points(:rows), general(:rows)) - printed(3)) <= 0.02_wp, &
            "printed exponents " // real_str(printed(1)) // ", " // real_str(printed(2)) // &
            ", " // real_str(printed(3)) // "; from the table " // &
            real_str(slope(points(:rows), compensated(:rows))) // ", " // &
            real_str(slope(points(:rows), naive(:rows))) // ", " // &
            real_str(slope(points(:rows), general(:rows))))

    contains

        !> Least-squares slope of log(values) against log(points) over positive values.
        pure real(wp) function slope(x_in, y_in)
            real(wp), intent(in) :: x_in(:), y_in(:)
            real(wp), allocatable :: x(:), y(:)
            x = log(pack(x_in, y_in > 0))
            y = log(pack(y_in, y_in > 0))
            slope = sum((x - sum(x) / size(x)) * (y - sum(y) / size(y))) / &
                    sum((x - sum(x) / size(x))**2)
        end function slope

    end subroutine cli_quick_report

end module test_extremes_cli
