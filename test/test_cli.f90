!> Tests of the command-line tool: the option parser (good options, each kind of bad
!! option), the number parsers, the dispatcher's exit codes, and `simulate` run in-process
!! into scratch files.
module test_cli
    use holosym_kinds, only: wp
    use holosym_status, only: holosym_status_t, int_str, real_str, HOLOSYM_INVALID_ARGUMENT
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close, &
        check_status_code, split_field
    use holosym_cli, only: cli_run
    use holosym_cli_common, only: cli_argument_t, split_words, parse_integer, parse_real, &
        EXIT_OK, EXIT_FAILURE, EXIT_USAGE
    use holosym_cli_simulate, only: simulate_config_t, simulate_summary_t, &
        parse_simulate_options, run_simulate, simulate_command, csv_header
    implicit none
    private
    public :: cli_tests

    !> Exact tolerance for values that must be parsed without rounding.
    real(wp), parameter :: exact = 0.0_wp
    !> Tolerance for decimal inputs that are not exact in binary.
    real(wp), parameter :: rounding = 4 * epsilon(1.0_wp)
    !> Significant digits the CSV must carry (real128 has 33 to 34).
    integer, parameter :: significant_digits = 33

contains

    !> The tests of this suite.
    function cli_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("split_words", test_split_words), &
            new_test("parse_defaults", test_parse_defaults), &
            new_test("parse_good_options", test_parse_good_options), &
            new_test("parse_inline_values_and_fractions", test_parse_inline), &
            new_test("parse_steps_override_t", test_parse_steps_override), &
            new_test("parse_t_not_multiple_of_h", test_parse_not_multiple), &
            new_test("parse_help", test_parse_help), &
            new_test("numbers_accepted", test_numbers_accepted), &
            new_test("numbers_rejected", test_numbers_rejected), &
            new_test("rejects_unknown_option", test_rejects_unknown_option), &
            new_test("rejects_missing_value", test_rejects_missing_value), &
            new_test("rejects_malformed_number", test_rejects_malformed_number), &
            new_test("rejects_out_of_range", test_rejects_out_of_range), &
            new_test("rejects_unknown_system", test_rejects_unknown_system), &
            new_test("csv_header", test_csv_header), &
            new_test("dispatcher_exit_codes", test_dispatcher_exit_codes), &
            new_test("simulate_in_process", test_simulate_in_process), &
            new_test("simulate_plain_same_rows", test_simulate_plain), &
            new_test("simulate_output_file", test_simulate_output_file), &
            new_test("simulate_integrator_failure", test_simulate_failure)]
    end function cli_tests

    ! ------------------------------------------------------------------ helpers

    !> Parse `line` as simulate options.
    subroutine parse_line(line, config, status)
        character(len=*), intent(in) :: line           !! options, blank-separated
        type(simulate_config_t), intent(out) :: config !! parsed settings
        type(holosym_status_t), intent(out) :: status  !! outcome
        call parse_simulate_options(split_words(line), config, status)
    end subroutine parse_line

    !> Check that `line` is rejected with a message containing every word of `names`.
    subroutine expect_rejection(error, line, names)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        character(len=*), intent(in) :: line     !! the options
        character(len=*), intent(in) :: names(:) !! texts the message must contain
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        integer :: i
        call parse_line(line, config, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "'" // line // "'")
        do i = 1, size(names)
            call check(error, index(status%message, trim(names(i))) > 0, "message for '" // &
                line // "' should name " // trim(names(i)) // ": " // status%message)
        end do
    end subroutine expect_rejection

    !> Read one line of any length from `unit`.
    subroutine read_line(unit, line, ios)
        integer, intent(in) :: unit                          !! open formatted unit
        character(len=:), allocatable, intent(out) :: line  !! the line
        integer, intent(out) :: ios                          !! 0, or iostat_end at the end
        character(len=256) :: chunk
        integer :: got
        line = ""
        do
            read (unit, '(a)', advance="no", iostat=ios, size=got) chunk
            line = line // chunk(:got)
            if (ios /= 0) exit
        end do
        if (is_iostat_eor(ios)) ios = 0
    end subroutine read_line

    !> All lines of `unit` from its start; the unit is left at its end, writable.
    subroutine read_all(unit, lines, count)
        integer, intent(in) :: unit !! open formatted unit
        type(cli_argument_t), allocatable, intent(out) :: lines(:) !! the lines
        integer, intent(out) :: count !! number of lines
        character(len=:), allocatable :: line
        integer :: ios
        rewind (unit)
        allocate (lines(0))
        do
            call read_line(unit, line, ios)
            if (ios /= 0) exit
            lines = [lines, cli_argument_t(line)]
        end do
        ! Step back over the end-of-file condition so that the unit can be written again.
        backspace (unit)
        count = size(lines)
    end subroutine read_all

    !> The k-th field of `line` read as a real; `ios` /= 0 when it is not a number.
    subroutine field_real(line, k, value, ios)
        character(len=*), intent(in) :: line !! a CSV line
        integer, intent(in) :: k             !! field number, from 1
        real(wp), intent(out) :: value       !! the number
        integer, intent(out) :: ios          !! iostat of the read
        character(len=:), allocatable :: text
        text = split_field(line, k, ",")
        value = 0
        read (text, *, iostat=ios) value
    end subroutine field_real

    !> Number of digits before the exponent of a number in scientific notation.
    pure integer function mantissa_digits(text)
        character(len=*), intent(in) :: text !! e.g. "-1.25E+0002"
        integer :: i
        mantissa_digits = 0
        do i = 1, len(text)
            if (scan(text(i:i), "eEdD") > 0) exit
            if (scan(text(i:i), "0123456789") > 0) mantissa_digits = mantissa_digits + 1
        end do
    end function mantissa_digits

    !> Number of comma-separated fields of `line`.
    pure integer function field_count(line)
        character(len=*), intent(in) :: line !! a CSV line
        integer :: i
        field_count = 1
        do i = 1, len(line)
            if (line(i:i) == ",") field_count = field_count + 1
        end do
    end function field_count

    ! ------------------------------------------------------------------ parser

    subroutine test_split_words(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(cli_argument_t), allocatable :: args(:)
        allocate (args, source=split_words("  simulate --M   3 "))
        call check(error, size(args) == 3, "three words")
        if (allocated(error)) return
        call check(error, args(1)%text == "simulate" .and. args(2)%text == "--M" .and. &
            args(3)%text == "3" .and. len(args(3)%text) == 1, "words and their lengths")
        call check(error, size(split_words("")) == 0, "no words in an empty line")
    end subroutine test_split_words

    subroutine test_parse_defaults(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        call parse_line("", config, status)
        call check(error, status%ok(), "no options: " // status%message)
        call check(error, config%system == "pendulum", "default system")
        call check(error, config%order_m == 2 .and. config%order_n == 1 .and. &
            config%gauss_points == 3, "default (M, N, G) = (2, 1, 3)")
        call check_close(error, config%step_size, 0.0625_wp, exact, exact, "default h")
        call check_close(error, config%final_time, 10.0_wp, exact, exact, "default T")
        call check(error, config%steps == 160, "default steps T/h = 160")
        call check(error, config%every == 1, "default every")
        call check(error, len(config%output) == 0 .and. len(config%note) == 0, &
            "no output file, no note")
        call check(error, .not. config%help, "no help")
    end subroutine test_parse_defaults

    subroutine test_parse_good_options(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        call parse_line("--system linkage --M 3 --N 2 --G 4 --h 0.0625 --T 1 --every 2 " // &
            "--output out.csv", config, status)
        call check(error, status%ok(), "good options: " // status%message)
        call check(error, config%system == "linkage", "system")
        call check(error, config%order_m == 3 .and. config%order_n == 2 .and. &
            config%gauss_points == 4, "(M, N, G) = (3, 2, 4)")
        call check_close(error, config%step_size, 0.0625_wp, exact, exact, "h")
        call check_close(error, config%final_time, 1.0_wp, exact, exact, "T")
        call check(error, config%steps == 16, "steps = T/h = 16")
        call check(error, config%every == 2, "every")
        call check(error, config%output == "out.csv", "output")
        call check(error, len(config%note) == 0, "T is a multiple of h: no note")
        ! Lower-case aliases and explicit G below the default are accepted as given.
        call parse_line("--m 4 --n 0 --g 2 --t 0.5 --h 0.1", config, status)
        call check(error, status%ok(), "lower-case aliases: " // status%message)
        call check(error, config%order_m == 4 .and. config%order_n == 0 .and. &
            config%gauss_points == 2, "(M, N, G) = (4, 0, 2)")
        call check_close(error, config%step_size, 0.1_wp, rounding, exact, "h = 0.1")
        call check(error, config%steps == 5, "0.5/0.1 is 5 steps within rounding")
        call check(error, len(config%note) == 0, "0.5/0.1: no note")
    end subroutine test_parse_good_options

    subroutine test_parse_inline(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        call parse_line("--system=planar --M=4 --h=1/8 --T=2", config, status)
        call check(error, status%ok(), "inline values: " // status%message)
        call check(error, config%system == "planar", "system")
        call check(error, config%order_m == 4 .and. config%order_n == 3 .and. &
            config%gauss_points == 5, "defaults N = M - 1 = 3, G = max(M, N) + 1 = 5")
        call check_close(error, config%step_size, 0.125_wp, exact, exact, "h = 1/8")
        call check(error, config%steps == 16, "steps = 2/(1/8) = 16")
        ! N above M - 1: G follows max(M, N) + 1.
        call parse_line("--M 1 --N 3", config, status)
        call check(error, status%ok() .and. config%gauss_points == 4, "G = max(1, 3) + 1")
    end subroutine test_parse_inline

    subroutine test_parse_steps_override(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        call parse_line("--steps 7 --T 100", config, status)
        call check(error, status%ok(), "steps and T: " // status%message)
        call check(error, config%steps == 7, "--steps overrides --T")
        call check(error, index(config%note, "overrides") > 0, "note says so: " // config%note)
        call parse_line("--steps 0", config, status)
        call check(error, status%ok() .and. config%steps == 0, "--steps 0 is allowed")
    end subroutine test_parse_steps_override

    subroutine test_parse_not_multiple(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        call parse_line("--T 1 --h 0.3", config, status)
        call check(error, status%ok(), "T not a multiple of h is not an error")
        call check(error, config%steps == 3, "nint(1/0.3) = 3 steps")
        call check(error, index(config%note, "nint") > 0, "a note explains: " // config%note)
        ! T/h beyond the integer range: 1e-4000 underflows to 0 in real64 (then --h is
        ! rejected as not > 0), so real64 uses the representable 1e-300 instead.
        call parse_line("--T 1 --h " // trim(merge("1e-4000", "1e-300 ", &
            precision(1.0_wp) >= 30)), config, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "T/h overflow")
        call check(error, index(status%message, "--T") > 0 .and. &
            index(status%message, "--h") > 0, "overflow names --T and --h: " // status%message)
    end subroutine test_parse_not_multiple

    subroutine test_parse_help(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        call parse_line("--M 3 --help --bogus", config, status)
        call check(error, status%ok() .and. config%help, "--help wins over what follows")
        call parse_line("-h", config, status)
        call check(error, status%ok() .and. config%help, "-h is help")
    end subroutine test_parse_help

    subroutine test_numbers_accepted(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(holosym_status_t) :: status
        real(wp) :: value
        integer :: number
        call parse_real("--h", "1e-3", value, status)
        call check_close(error, value, 1.0e-3_wp, rounding, exact, "1e-3")
        call parse_real("--h", "-2.5D0", value, status)
        call check_close(error, value, -2.5_wp, exact, exact, "-2.5D0")
        call parse_real("--h", "+.5", value, status)
        call check_close(error, value, 0.5_wp, exact, exact, "+.5")
        call parse_real("--h", "3.", value, status)
        call check_close(error, value, 3.0_wp, exact, exact, "3.")
        call parse_real("--h", "1/16", value, status)
        call check_close(error, value, 0.0625_wp, exact, exact, "1/16")
        call parse_real("--h", "0.1", value, status)
        call check_close(error, value, 0.1_wp, exact, exact, "0.1 read in real128")
        call parse_integer("--M", "+12", number, status)
        call check(error, status%ok() .and. number == 12, "+12")
        call parse_integer("--M", "-3", number, status)
        call check(error, status%ok() .and. number == -3, "-3")
    end subroutine test_numbers_accepted

    subroutine test_numbers_rejected(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: bad_reals(*) = [character(len=8) :: &
            "", ".", "1e", "1.2.3", "inf", "nan", "1/0", "1 2", "1,2", "e5", "--1", "1e+", "1/"]
        character(len=*), parameter :: bad_integers(*) = [character(len=24) :: &
            "", "+", "1e3", "1.0", "x1", "1 2", "99999999999999999999"]
        type(holosym_status_t) :: status
        real(wp) :: value
        integer :: number, i
        do i = 1, size(bad_reals)
            call parse_real("--h", trim(bad_reals(i)), value, status)
            call check(error, status%code == HOLOSYM_INVALID_ARGUMENT .and. &
                index(status%message, "--h") > 0, "real '" // trim(bad_reals(i)) // &
                "' must be rejected naming --h")
        end do
        do i = 1, size(bad_integers)
            call parse_integer("--M", trim(bad_integers(i)), number, status)
            call check(error, status%code == HOLOSYM_INVALID_ARGUMENT .and. &
                index(status%message, "--M") > 0, "integer '" // trim(bad_integers(i)) // &
                "' must be rejected naming --M")
        end do
    end subroutine test_numbers_rejected

    subroutine test_rejects_unknown_option(error)
        type(test_error_t), allocatable, intent(out) :: error
        call expect_rejection(error, "--M 3 --frobnicate 1", ["--frobnicate"])
        call expect_rejection(error, "--x", ["--x"])
        call expect_rejection(error, "stray", ["stray"])
        call expect_rejection(error, "--help=yes", ["--help"])
    end subroutine test_rejects_unknown_option

    subroutine test_rejects_missing_value(error)
        type(test_error_t), allocatable, intent(out) :: error
        call expect_rejection(error, "--M", ["--M"])
        call expect_rejection(error, "--h --T 1", ["--h"])
        call expect_rejection(error, "--T=", ["--T"])
        call expect_rejection(error, "--output", ["--output"])
        call expect_rejection(error, "--system", ["--system"])
    end subroutine test_rejects_missing_value

    subroutine test_rejects_malformed_number(error)
        type(test_error_t), allocatable, intent(out) :: error
        call expect_rejection(error, "--M three", [character(len=8) :: "--M", "three"])
        call expect_rejection(error, "--N 1.5", [character(len=8) :: "--N", "1.5"])
        call expect_rejection(error, "--G 4x", [character(len=8) :: "--G", "4x"])
        call expect_rejection(error, "--h 0.1.2", [character(len=8) :: "--h", "0.1.2"])
        call expect_rejection(error, "--T ten", [character(len=8) :: "--T", "ten"])
        call expect_rejection(error, "--steps 1e3", [character(len=8) :: "--steps", "1e3"])
        call expect_rejection(error, "--every two", [character(len=8) :: "--every", "two"])
    end subroutine test_rejects_malformed_number

    subroutine test_rejects_out_of_range(error)
        type(test_error_t), allocatable, intent(out) :: error
        call expect_rejection(error, "--M 0", [character(len=8) :: "--M", "'0'"])
        call expect_rejection(error, "--N -1", [character(len=8) :: "--N", "'-1'"])
        call expect_rejection(error, "--G 0", [character(len=8) :: "--G", "'0'"])
        call expect_rejection(error, "--h 0", [character(len=8) :: "--h", "'0'"])
        call expect_rejection(error, "--h -0.5", [character(len=8) :: "--h", "'-0.5'"])
        call expect_rejection(error, "--T -1", [character(len=8) :: "--T", "'-1'"])
        call expect_rejection(error, "--steps -2", [character(len=8) :: "--steps", "'-2'"])
        call expect_rejection(error, "--every 0", [character(len=8) :: "--every", "'0'"])
    end subroutine test_rejects_out_of_range

    subroutine test_rejects_unknown_system(error)
        type(test_error_t), allocatable, intent(out) :: error
        call expect_rejection(error, "--system moon", [character(len=8) :: "--system", "moon"])
        call expect_rejection(error, "--system Pendulum", &
            [character(len=9) :: "--system", "Pendulum"])
    end subroutine test_rejects_unknown_system

    ! ------------------------------------------------------------------ output and runs

    subroutine test_csv_header(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check(error, csv_header(3, 1) == "t,q1,q2,q3,p1,p2,p3,lambda1,H,energy_error," // &
            "constraint_residual,velocity_residual,newton_iterations", "header n = 3, m = 1")
        call check(error, csv_header(6, 3) == "t,q1,q2,q3,q4,q5,q6,p1,p2,p3,p4,p5,p6," // &
            "lambda1,lambda2,lambda3,H,energy_error,constraint_residual,velocity_residual," // &
            "newton_iterations", "header n = 6, m = 3")
    end subroutine test_csv_header

    subroutine test_dispatcher_exit_codes(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: out, err, code, count
        type(cli_argument_t), allocatable :: lines(:)
        open (newunit=out, status="scratch", action="readwrite")
        open (newunit=err, status="scratch", action="readwrite")
        call cli_run(split_words("--help"), out, err, code)
        call check(error, code == EXIT_OK, "holosym --help exits 0")
        call read_all(out, lines, count)
        call check(error, count > 0, "help printed")
        if (count > 0) call check(error, index(lines(1)%text, "Usage") > 0, "help has usage")
        call cli_run(split_words(""), out, err, code)
        call check(error, code == EXIT_USAGE, "no command exits 2")
        call cli_run(split_words("frobnicate"), out, err, code)
        call check(error, code == EXIT_USAGE, "unknown command exits 2")
        call cli_run(split_words("simulate --help"), out, err, code)
        call check(error, code == EXIT_OK, "simulate --help exits 0")
        call cli_run(split_words("help simulate"), out, err, code)
        call check(error, code == EXIT_OK, "help simulate exits 0")
        call cli_run(split_words("simulate --M 0"), out, err, code)
        call check(error, code == EXIT_USAGE, "bad option exits 2")
        close (err)
        open (newunit=err, status="scratch", action="readwrite")
        call simulate_command(split_words("--every 0"), out, err, code)
        call check(error, code == EXIT_USAGE, "simulate_command: bad option exits 2")
        call read_all(err, lines, count)
        call check(error, count > 0, "the error is reported on the error unit")
        if (count > 0) call check(error, index(lines(1)%text, "--every") > 0, &
            "the message names --every: " // lines(1)%text)
        close (out)
        close (err)
    end subroutine test_dispatcher_exit_codes

    subroutine test_simulate_in_process(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(simulate_config_t) :: config
        type(simulate_summary_t) :: summary
        type(holosym_status_t) :: status
        type(cli_argument_t), allocatable :: lines(:)
        integer :: out, err, count, i, ios
        real(wp) :: t, energy_error, h

        call parse_line("--system pendulum --steps 5 --every 2", config, status)
        call check(error, status%ok(), "parse: " // status%message)
        if (allocated(error)) return
        open (newunit=out, status="scratch", action="readwrite")
        open (newunit=err, status="scratch", action="readwrite")
        call run_simulate(config, out, err, status, summary)
        call check(error, status%ok(), "run: " // status%message)
        call read_all(out, lines, count)
        close (out)
        close (err)
        if (allocated(error)) return
        ! Rows at t = 0 and after steps 2, 4 and 5 (the last step).
        call check(error, count == 5, "header + 4 rows; got " // int_str(count) // " lines")
        call check(error, summary%rows == 4 .and. summary%steps_done == 5, "summary counts")
        if (allocated(error)) return
        call check(error, lines(1)%text == csv_header(3, 1), "header: " // lines(1)%text)
        do i = 2, count
            call check(error, field_count(lines(i)%text) == 13, "13 fields in row " // &
                int_str(i - 1))
            call check(error, index(lines(i)%text, " ") == 0, "no blanks in row " // &
                int_str(i - 1))
        end do
        if (allocated(error)) return
        call field_real(lines(2)%text, 1, t, ios)
        call check(error, ios == 0, "t of the first row is a number")
        call check_close(error, t, 0.0_wp, exact, exact, "first row at t = 0")
        call field_real(lines(2)%text, 10, energy_error, ios)
        call check(error, ios == 0, "energy_error of the first row is a number")
        call check_close(error, energy_error, 0.0_wp, exact, exact, "energy_error at t = 0")
        call check(error, split_field(lines(2)%text, 13, ",") == "0", "0 Newton iterations at t = 0")
        call check(error, mantissa_digits(split_field(lines(2)%text, 3, ",")) >= significant_digits, &
            "at least 33 significant digits: " // split_field(lines(2)%text, 3, ","))
        h = config%step_size
        call field_real(lines(count)%text, 1, t, ios)
        call check_close(error, t, 5 * h, exact, exact, "last row at t = 5 h")
        call field_real(lines(3)%text, 1, t, ios)
        call check_close(error, t, 2 * h, exact, exact, "second row at t = 2 h")
        call field_real(lines(count)%text, 10, energy_error, ios)
        call check(error, abs(energy_error) <= summary%max_energy_error, &
            "last energy error within the summary maximum")
        ! (M, N) = (2, 1) has order 2M = 4: over a few steps the energy error is far below h**4.
        call check(error, summary%max_energy_error > 0 .and. &
            summary%max_energy_error < h**4, "small nonzero energy error")
    end subroutine test_simulate_in_process

    !> --plain is a flag (a value is rejected) and gives the rows of the default (fast) run
    !! to round-off.
    subroutine test_simulate_plain(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        type(cli_argument_t), allocatable :: plain(:), fast(:)
        integer :: count_plain, count_fast, i, k, ios
        real(wp) :: a, b, difference
        character(len=*), parameter :: options = "--system linkage --M 3 --h 1/4 --steps 8"

        call parse_line("--plain", config, status)
        call check(error, status%ok() .and. config%plain, "--plain sets the flag")
        call expect_rejection(error, "--plain=yes", ["--plain"])
        call run_lines(options // " --plain", plain, count_plain)
        call run_lines(options, fast, count_fast)
        if (allocated(error)) return
        call check(error, count_plain == count_fast .and. count_plain == 10, "rows: " // &
            int_str(count_plain) // " and " // int_str(count_fast))
        if (allocated(error)) return
        difference = 0
        do i = 2, count_plain
            do k = 1, 13   ! t, q (6), p (6)
                call field_real(plain(i)%text, k, a, ios)
                call field_real(fast(i)%text, k, b, ios)
                difference = max(difference, abs(a - b))
            end do
        end do
        call check(error, difference <= max(1.0e-30_wp, 1.0e4_wp * epsilon(1.0_wp)), &
            "--plain changes the state by " // real_str(difference))
    contains
        subroutine run_lines(line, lines, count)
            character(len=*), intent(in) :: line
            type(cli_argument_t), allocatable, intent(out) :: lines(:)
            integer, intent(out) :: count
            integer :: out, err
            count = 0
            call parse_line(line, config, status)
            call check(error, status%ok(), "parse '" // line // "': " // status%message)
            if (allocated(error)) return
            open (newunit=out, status="scratch", action="readwrite")
            open (newunit=err, status="scratch", action="readwrite")
            call run_simulate(config, out, err, status)
            call check(error, status%ok(), "run '" // line // "': " // status%message)
            call read_all(out, lines, count)
            close (out)
            close (err)
        end subroutine run_lines
    end subroutine test_simulate_plain

    subroutine test_simulate_output_file(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: path = "holosym_test_cli_output.csv"
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status
        type(cli_argument_t), allocatable :: lines(:)
        integer :: out, err, unit, count

        call parse_line("--system linkage --M 3 --N 2 --G 4 --h 1/16 --steps 2 --output " // &
            path, config, status)
        call check(error, status%ok(), "parse: " // status%message)
        if (allocated(error)) return
        open (newunit=out, status="scratch", action="readwrite")
        open (newunit=err, status="scratch", action="readwrite")
        call run_simulate(config, out, err, status)
        call check(error, status%ok(), "run: " // status%message)
        call read_all(out, lines, count)
        call check(error, count == 0, "nothing on the output unit with --output")
        close (out)
        close (err)
        open (newunit=unit, file=path, status="old", action="read")
        call read_all(unit, lines, count)
        close (unit, status="delete")
        call check(error, count == 4, "header + rows at steps 0, 1, 2 in the file")
        if (count > 0) call check(error, lines(1)%text == csv_header(6, 3), "linkage header")
        if (count > 1) call check(error, field_count(lines(2)%text) == 21, "21 fields")
    end subroutine test_simulate_output_file

    subroutine test_simulate_failure(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(cli_argument_t), allocatable :: lines(:)
        integer :: out, err, code, count
        open (newunit=out, status="scratch", action="readwrite")
        open (newunit=err, status="scratch", action="readwrite")
        ! M = N + 2 is singular on the pendulum (rotational symmetry): a run-time failure.
        call simulate_command(split_words("--M 3 --N 1 --G 4 --steps 3"), out, err, code)
        call check(error, code == EXIT_FAILURE, "integrator failure exits 1")
        call read_all(out, lines, count)
        call check(error, count == 1, "the header stays written")
        call read_all(err, lines, count)
        call check(error, count > 0, "a message on the error unit")
        if (count > 0) call check(error, index(lines(count)%text, "error") > 0, &
            "the last message reports the error: " // lines(count)%text)
        close (out)
        close (err)
    end subroutine test_simulate_failure

end module test_cli
