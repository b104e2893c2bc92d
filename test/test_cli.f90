!> Tests of the `holosym` executable's dispatcher and `simulate` command, run as a user
!! runs them: options accepted (read back from the start line on standard error and from
!! the CSV), each kind of bad option rejected with exit status 2 and a message naming the
!! option and the value, the number syntax, the exit codes, and the CSV written.
module test_cli
    use holosym_kinds, only: wp
    use holosym_status_codes, only: int_str, real_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close, &
        split_field
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, &
        scratch_path, read_lines, file_exists, any_line_contains
    implicit none
    private
    public :: cli_tests

    !> Exact tolerance for values that must be parsed without rounding.
    real(wp), parameter :: exact = 0.0_wp
    !> Tolerance for decimal inputs that are not exact in binary.
    real(wp), parameter :: rounding = 4 * epsilon(1.0_wp)
    !> Significant digits the CSV must carry (real128 has 33 to 34).
    integer, parameter :: significant_digits = 33
    !> Exit status of a command that failed, and of bad usage.
    integer, parameter :: exit_failure = 1, exit_usage = 2
    !> The hint that ends every usage error of `simulate`.
    character(len=*), parameter :: simulate_hint = "Run 'holosym simulate --help' for the options."

contains

    !> The tests of this suite.
    function cli_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("defaults", test_defaults), &
            new_test("good_options", test_good_options), &
            new_test("inline_values_and_fractions", test_inline), &
            new_test("steps_override_t", test_steps_override), &
            new_test("t_not_multiple_of_h", test_not_multiple), &
            new_test("help", test_help), &
            new_test("numbers_accepted", test_numbers_accepted), &
            new_test("numbers_rejected", test_numbers_rejected), &
            new_test("rejects_unknown_option", test_rejects_unknown_option), &
            new_test("rejects_missing_value", test_rejects_missing_value), &
            new_test("rejects_malformed_number", test_rejects_malformed_number), &
            new_test("rejects_out_of_range", test_rejects_out_of_range), &
            new_test("rejects_unknown_system", test_rejects_unknown_system), &
            new_test("chain_links", test_chain_links), &
            new_test("csv_header", test_csv_header), &
            new_test("dispatcher_exit_codes", test_dispatcher_exit_codes), &
            new_test("simulate_rows", test_simulate_rows), &
            new_test("simulate_plain_same_rows", test_simulate_plain), &
            new_test("simulate_output_file", test_simulate_output_file), &
            new_test("simulate_integrator_failure", test_simulate_failure)]
    end function cli_tests

    ! ------------------------------------------------------------------ helpers

    !> Run `holosym simulate` with the blank-separated options of `line`; fail unless it
    !! ran (any exit status).
    subroutine simulate(error, line, result)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        character(len=*), intent(in) :: line            !! options
        type(command_result_t), intent(out) :: result   !! what it did
        call run_holosym("simulate " // line, result)
        call check(error, len(result%failure) == 0, result%failure)
    end subroutine simulate

    !> The start line of a `simulate` run on standard error ("" if none).
    function start_line(result) result(line)
        type(command_result_t), intent(in) :: result !! a simulate run
        character(len=:), allocatable :: line
        integer :: i
        line = ""
        do i = 1, size(result%err)
            if (index(result%err(i)%text, "(M, N, G) = (") > 0) then
                line = result%err(i)%text
                return
            end if
        end do
    end function start_line

    !> The start line as `simulate` writes it for these settings.
    function expected_start(system, n, m, order_m, order_n, gauss, h, steps) result(line)
        character(len=*), intent(in) :: system    !! system name
        integer, intent(in) :: n, m               !! its coordinates and constraints
        integer, intent(in) :: order_m, order_n, gauss !! (M, N, G)
        real(wp), intent(in) :: h                 !! step size
        integer, intent(in) :: steps              !! number of steps
        character(len=:), allocatable :: line
        line = "holosym simulate: " // system // " (n = " // int_str(n) // ", m = " // &
            int_str(m) // "), (M, N, G) = (" // int_str(order_m) // ", " // int_str(order_n) &
            // ", " // int_str(gauss) // "), h = " // real_str(h) // ", " // int_str(steps) &
            // " steps to t = " // real_str(steps * h)
    end function expected_start

    !> Check that the run started with these settings and was not a usage error.
    subroutine check_start(error, result, expected, what)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        type(command_result_t), intent(in) :: result  !! a simulate run
        character(len=*), intent(in) :: expected      !! from `expected_start`
        character(len=*), intent(in) :: what          !! the options, for messages
        call check(error, result%exit_code /= exit_usage, what // ": usage error")
        call check(error, start_line(result) == expected, what // ": start line '" // &
            start_line(result) // "', expected '" // expected // "'")
    end subroutine check_start

    !> Check that `holosym simulate ARGS` is a usage error (exit 2, the hint) whose message
    !! contains every text of `names`.
    subroutine expect_rejection_args(error, args, names)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        character(len=*), intent(in) :: args(:)  !! arguments after "simulate"
        character(len=*), intent(in) :: names(:) !! texts the message must contain
        type(command_result_t) :: result
        character(len=:), allocatable :: shown, message
        integer :: i
        shown = ""
        do i = 1, size(args)
            shown = shown // " " // trim(args(i))
        end do
        call run_holosym(with_command(args), result)
        call check(error, len(result%failure) == 0, result%failure)
        call check(error, result%exit_code == exit_usage, "'" // shown // "': exit " // &
            int_str(result%exit_code) // ", expected 2")
        call check(error, size(result%err) == 2 .and. size(result%out) == 0, "'" // shown // &
            "': a message and the hint on standard error, nothing on standard output")
        if (allocated(error)) return
        call check(error, result%err(2)%text == simulate_hint, "'" // shown // "': hint " // &
            result%err(2)%text)
        message = result%err(1)%text
        do i = 1, size(names)
            call check(error, index(message, trim(names(i))) > 0, "message for '" // shown // &
                "' should name " // trim(names(i)) // ": " // message)
        end do
    end subroutine expect_rejection_args

    !> "simulate" followed by `args`.
    pure function with_command(args) result(list)
        character(len=*), intent(in) :: args(:) !! the options
        character(len=max(8, len(args))) :: list(size(args) + 1)
        list(1) = "simulate"
        list(2:) = args
    end function with_command

    !> `expect_rejection_args` for options separated by blanks.
    subroutine expect_rejection(error, line, names)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        character(len=*), intent(in) :: line     !! the options
        character(len=*), intent(in) :: names(:) !! texts the message must contain
        character(len=len(line)), allocatable :: words(:)
        integer :: first, last
        allocate (words(0))
        last = 0
        do
            first = verify(line(last + 1:), " ")
            if (first == 0) exit
            first = last + first
            last = index(line(first:), " ")
            if (last == 0) then
                last = len(line) + 1
            else
                last = first + last - 1
            end if
            words = [character(len=len(line)) :: words, line(first:last - 1)]
            if (last >= len(line)) exit
        end do
        call expect_rejection_args(error, words, names)
    end subroutine expect_rejection

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

    !> t of a CSV row (-1 when it is not a number).
    real(wp) function row_time(line) result(t)
        character(len=*), intent(in) :: line !! a CSV row
        integer :: ios
        call field_real(line, 1, t, ios)
        if (ios /= 0) t = -1
    end function row_time

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

    !> The step size that `simulate --h TEXT --steps 1` used: t of its last CSV row, which
    !! carries 36 significant digits (exact in real128).
    subroutine parsed_step(error, text, h)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        character(len=*), intent(in) :: text !! the value of --h
        real(wp), intent(out) :: h           !! t after the one step
        type(command_result_t) :: result
        integer :: ios
        h = 0
        call simulate(error, "--h " // text // " --steps 1", result)
        call check(error, result%exit_code == 0 .and. size(result%out) == 3, "--h " // text // &
            ": exit " // int_str(result%exit_code) // ", " // int_str(size(result%out)) // &
            " lines")
        if (allocated(error)) return
        call field_real(result%out(3)%text, 1, h, ios)
        call check(error, ios == 0, "--h " // text // ": t is a number")
    end subroutine parsed_step

    ! ------------------------------------------------------------------ options

    !> Without options: the spherical pendulum, (M, N, G) = (2, 1, 3), h = 1/16, T = 10
    !! (160 steps), every row, to standard output, no note.
    subroutine test_defaults(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call simulate(error, "", result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "exit " // int_str(result%exit_code))
        call check_start(error, result, expected_start("pendulum", 3, 1, 2, 1, 3, 0.0625_wp, &
                         160), "no options")
        call check(error, size(result%out) == 162, "header + 161 rows on standard output; got " &
            // int_str(size(result%out)) // " lines")
        call check(error, .not. any_line_contains(result%err, "note:"), "no note")
        if (allocated(error)) return
        ! h and T exactly: t after the first step and after the last (36 digits in the CSV).
        call check_close(error, row_time(result%out(3)%text), 0.0625_wp, exact, exact, &
            "default h")
        call check_close(error, row_time(result%out(162)%text), 10.0_wp, exact, exact, &
            "default T")
    end subroutine test_defaults

    subroutine test_good_options(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: path
        integer :: ios
        path = scratch_path("cli_good_options.csv")
        call simulate(error, "--system linkage --M 3 --N 2 --G 4 --h 0.0625 --T 1 --every 2 " &
            // "--output " // path, result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "exit " // int_str(result%exit_code))
        call check_start(error, result, expected_start("linkage", 6, 3, 3, 2, 4, 0.0625_wp, 16), &
                         "linkage options")
        call check(error, .not. any_line_contains(result%err, "note:"), &
            "T is a multiple of h: no note")
        call check(error, size(result%out) == 0, "nothing on standard output with --output")
        call read_lines(path, lines, ios)
        call check(error, ios == 0 .and. size(lines) == 10, "header + rows at steps 0, 2, .., 16 " &
            // "in --output; got " // int_str(size(lines)) // " lines")
        if (allocated(error)) return
        call check_close(error, row_time(lines(3)%text), 0.125_wp, exact, exact, "2 h")
        call check_close(error, row_time(lines(10)%text), 1.0_wp, exact, exact, "T")
        ! Lower-case aliases and explicit G below the default are taken as given; 0.5/0.1 is
        ! 5 steps within rounding (the run itself fails: (4, 0) is singular on the pendulum).
        call simulate(error, "--m 4 --n 0 --g 2 --t 0.5 --h 0.1", result)
        if (allocated(error)) return
        call check_start(error, result, expected_start("pendulum", 3, 1, 4, 0, 2, 0.1_wp, 5), &
                         "lower-case aliases")
        call check(error, .not. any_line_contains(result%err, "note:"), "0.5/0.1: no note")
    end subroutine test_good_options

    subroutine test_inline(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call simulate(error, "--system=planar --M=4 --h=1/8 --T=2", result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "exit " // int_str(result%exit_code))
        ! Defaults N = M - 1 = 3, G = max(M, N) + 1 = 5; steps = 2/(1/8) = 16.
        call check_start(error, result, expected_start("planar", 2, 1, 4, 3, 5, 0.125_wp, 16), &
                         "inline values")
        call check(error, size(result%out) == 18, "header + 17 rows")
        if (allocated(error)) return
        call check_close(error, row_time(result%out(3)%text), 0.125_wp, exact, exact, "h = 1/8")
        call check_close(error, row_time(result%out(18)%text), 2.0_wp, exact, exact, "T = 2")
        ! N above M - 1: G follows max(M, N) + 1.
        call simulate(error, "--M 1 --N 3 --steps 0", result)
        call check_start(error, result, expected_start("pendulum", 3, 1, 1, 3, 4, 0.0625_wp, 0), &
                         "--M 1 --N 3")
    end subroutine test_inline

    subroutine test_steps_override(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call simulate(error, "--steps 7 --T 100", result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "exit " // int_str(result%exit_code))
        call check_start(error, result, expected_start("pendulum", 3, 1, 2, 1, 3, 0.0625_wp, 7), &
                         "--steps overrides --T")
        call check(error, any_line_contains(result%err, "note: --steps 7 overrides --T"), &
            "a note says so")
        call simulate(error, "--steps 0", result)
        call check(error, result%exit_code == 0 .and. size(result%out) == 2, &
            "--steps 0 is allowed: the header and the row at t = 0")
    end subroutine test_steps_override

    subroutine test_not_multiple(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call simulate(error, "--T 1 --h 0.3", result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "T not a multiple of h is not an error")
        call check_start(error, result, expected_start("pendulum", 3, 1, 2, 1, 3, 0.3_wp, 3), &
                         "nint(1/0.3) = 3 steps")
        call check(error, any_line_contains(result%err, "nint(T/h) = 3 steps"), &
            "a note explains")
        ! T/h beyond the integer range: 1e-4000 underflows to 0 in real64 (then --h is
        ! rejected as not > 0), so real64 uses the representable 1e-300 instead.
        call expect_rejection(error, "--T 1 --h " // trim(merge("1e-4000", "1e-300 ", &
            precision(1.0_wp) >= 30)), [character(len=8) :: "--T", "--h"])
    end subroutine test_not_multiple

    subroutine test_help(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call run_holosym("simulate --M 3 --help --bogus", result)
        call check(error, result%exit_code == 0 .and. size(result%out) > 0, &
            "--help wins over what follows")
        if (allocated(error)) return
        call check(error, result%out(1)%text == "Usage: holosym simulate [options]", &
            "the help: " // result%out(1)%text)
        call run_holosym("simulate -h", result)
        call check(error, result%exit_code == 0 .and. &
            any_line_contains(result%out, "Usage: holosym simulate"), "-h is help")
    end subroutine test_help

    ! ------------------------------------------------------------------ numbers

    subroutine test_numbers_accepted(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        real(wp) :: h
        call parsed_step(error, "1e-3", h)
        call check_close(error, h, 1.0e-3_wp, rounding, exact, "1e-3")
        call parsed_step(error, "+.5", h)
        call check_close(error, h, 0.5_wp, exact, exact, "+.5")
        call parsed_step(error, "1/16", h)
        call check_close(error, h, 0.0625_wp, exact, exact, "1/16")
        call parsed_step(error, "0.1", h)
        call check_close(error, h, 0.1_wp, exact, exact, "0.1 read in working precision")
        call parsed_step(error, "2.5D-1", h)
        call check_close(error, h, 0.25_wp, exact, exact, "2.5D-1")
        ! A negative number is a number: rejected for its range, not its syntax.
        call expect_rejection(error, "--h -2.5D0", [character(len=16) :: "--h", "must be > 0", &
                              "'-2.5D0'"])
        ! "3." is T = 3: 6 steps of h = 1/2.
        call simulate(error, "--T 3. --h 0.5", result)
        call check_start(error, result, expected_start("pendulum", 3, 1, 2, 1, 3, 0.5_wp, 6), &
                         "--T 3.")
        call check(error, .not. any_line_contains(result%err, "note:"), "--T 3.: T/h = 6, no note")
        call simulate(error, "--M +12 --steps 0", result)
        call check_start(error, result, expected_start("pendulum", 3, 1, 12, 11, 13, 0.0625_wp, &
                         0), "--M +12")
        call expect_rejection(error, "--N -3", [character(len=16) :: "--N", "must be in 0..30", &
                              "'-3'"])
    end subroutine test_numbers_accepted

    subroutine test_numbers_rejected(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: bad_reals(*) = [character(len=8) :: &
            ".", "1e", "1.2.3", "inf", "nan", "1 2", "1,2", "e5", "1e+", "1/"]
        character(len=*), parameter :: bad_integers(*) = [character(len=24) :: &
            "+", "1e3", "1.0", "x1", "1 2", "99999999999999999999"]
        integer :: i
        do i = 1, size(bad_reals)
            call expect_rejection_args(error, [character(len=8) :: "--h", bad_reals(i)], &
                [character(len=20) :: "option --h", "expects a number", "'" // &
                trim(bad_reals(i)) // "'"])
        end do
        ! An empty value is no value; a zero denominator is named.
        call expect_rejection_args(error, [character(len=8) :: "--h", ""], &
            [character(len=20) :: "option --h", "needs a value"])
        call expect_rejection_args(error, [character(len=8) :: "--h", "1/0"], &
            [character(len=20) :: "option --h", "division by zero", "'1/0'"])
        ! "--1" looks like an option: --h then has no value.
        call expect_rejection(error, "--h --1", [character(len=16) :: "--h", "needs a value"])
        do i = 1, size(bad_integers)
            call expect_rejection_args(error, [character(len=24) :: "--M", bad_integers(i)], &
                [character(len=28) :: "option --M", "'" // trim(bad_integers(i)) // "'"])
        end do
    end subroutine test_numbers_rejected

    ! ------------------------------------------------------------------ bad options

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

    !> The chain of K pendula: --links sets K (n = 2K, m = K), in 1..100000, only with
    !! --system chain; a short run keeps the constraints.
    subroutine test_chain_links(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call simulate(error, "--system chain --links 3 --steps 0", result)
        call check(error, size(result%out) >= 1, "a chain header")
        if (allocated(error)) return
        call check(error, result%out(1)%text == "t,q1,q2,q3,q4,q5,q6,p1,p2,p3,p4,p5,p6," // &
            "lambda1,lambda2,lambda3,H,energy_error,constraint_residual,velocity_residual," // &
            "newton_iterations", "header n = 6, m = 3: " // result%out(1)%text)
        call simulate(error, "--system chain --links 2 --M 4 --h 0.01 --steps 3", result)
        call check(error, result%exit_code == 0 .and. size(result%out) == 5, &
            "three steps of the double pendulum: exit " // int_str(result%exit_code))
        call simulate(error, "--system chain --steps 0", result)
        call check(error, index(result%out(1)%text, "q16,p1,") > 0, "default K = 8")
        call expect_rejection(error, "--system chain --links 0", &
            [character(len=8) :: "--links", "0"])
        call expect_rejection(error, "--system chain --links 100001", &
            [character(len=8) :: "--links", "100001"])
        call expect_rejection(error, "--system chain --links two", &
            [character(len=8) :: "--links", "two"])
        call expect_rejection(error, "--system planar --links 3", &
            [character(len=14) :: "--links", "--system chain"])
    end subroutine test_chain_links

    ! ------------------------------------------------------------------ output and runs

    subroutine test_csv_header(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call simulate(error, "--steps 0", result)
        call check(error, size(result%out) >= 1, "a header")
        if (allocated(error)) return
        call check(error, result%out(1)%text == "t,q1,q2,q3,p1,p2,p3,lambda1,H,energy_error," &
            // "constraint_residual,velocity_residual,newton_iterations", "header n = 3, m = 1")
        call simulate(error, "--system linkage --steps 0", result)
        call check(error, size(result%out) >= 1, "a linkage header")
        if (allocated(error)) return
        call check(error, result%out(1)%text == "t,q1,q2,q3,q4,q5,q6,p1,p2,p3,p4,p5,p6," // &
            "lambda1,lambda2,lambda3,H,energy_error,constraint_residual,velocity_residual," // &
            "newton_iterations", "header n = 6, m = 3")
    end subroutine test_csv_header

    subroutine test_dispatcher_exit_codes(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call run_holosym("--help", result)
        call check(error, len(result%failure) == 0, result%failure)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "holosym --help exits 0")
        call check(error, size(result%out) > 0, "help printed")
        if (size(result%out) > 0) call check(error, index(result%out(1)%text, "Usage") > 0, &
            "help has usage")
        call run_holosym("", result)
        call check(error, result%exit_code == exit_usage .and. &
            any_line_contains(result%err, "Usage"), "no command exits 2, the help on stderr")
        call run_holosym("frobnicate", result)
        call check(error, result%exit_code == exit_usage .and. &
            any_line_contains(result%err, "unknown command 'frobnicate'"), &
            "unknown command exits 2")
        call run_holosym("simulate --help", result)
        call check(error, result%exit_code == 0, "simulate --help exits 0")
        call run_holosym("help simulate", result)
        call check(error, result%exit_code == 0 .and. &
            any_line_contains(result%out, "Usage: holosym simulate"), "help simulate exits 0")
        call run_holosym("simulate --M 0", result)
        call check(error, result%exit_code == exit_usage, "bad option exits 2")
        call run_holosym("simulate --every 0", result)
        call check(error, result%exit_code == exit_usage, "--every 0 exits 2")
        call check(error, size(result%err) > 0, "the error is reported on standard error")
        if (size(result%err) > 0) call check(error, index(result%err(1)%text, "--every") > 0, &
            "the message names --every: " // result%err(1)%text)
    end subroutine test_dispatcher_exit_codes

    subroutine test_simulate_rows(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        integer :: count, i, ios
        real(wp) :: t, energy_error, h, max_energy_error, largest

        call simulate(error, "--system pendulum --steps 5 --every 2", result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "exit " // int_str(result%exit_code))
        count = size(result%out)
        ! Rows at t = 0 and after steps 2, 4 and 5 (the last step).
        call check(error, count == 5, "header + 4 rows; got " // int_str(count) // " lines")
        call check(error, any_line_contains(result%err, "holosym simulate: 5 steps, 4 rows in"), &
            "summary counts")
        if (allocated(error)) return
        call check(error, result%out(1)%text == "t,q1,q2,q3,p1,p2,p3,lambda1,H,energy_error," &
            // "constraint_residual,velocity_residual,newton_iterations", "header")
        do i = 2, count
            call check(error, field_count(result%out(i)%text) == 13, "13 fields in row " // &
                int_str(i - 1))
            call check(error, index(result%out(i)%text, " ") == 0, "no blanks in row " // &
                int_str(i - 1))
        end do
        if (allocated(error)) return
        associate (first => result%out(2)%text, last => result%out(count)%text)
            call field_real(first, 1, t, ios)
            call check(error, ios == 0, "t of the first row is a number")
            call check_close(error, t, 0.0_wp, exact, exact, "first row at t = 0")
            call field_real(first, 10, energy_error, ios)
            call check(error, ios == 0, "energy_error of the first row is a number")
            call check_close(error, energy_error, 0.0_wp, exact, exact, "energy_error at t = 0")
            call check(error, split_field(first, 13, ",") == "0", "0 Newton iterations at t = 0")
            call check(error, mantissa_digits(split_field(first, 3, ",")) >= &
                significant_digits, "at least 33 significant digits: " // &
                split_field(first, 3, ","))
            h = 0.0625_wp
            call field_real(last, 1, t, ios)
            call check_close(error, t, 5 * h, exact, exact, "last row at t = 5 h")
            call field_real(result%out(3)%text, 1, t, ios)
            call check_close(error, t, 2 * h, exact, exact, "second row at t = 2 h")
        end associate
        ! The summary's maximum covers every step, written or not, with 6 digits.
        max_energy_error = summary_value(result, "max |energy error| ")
        largest = 0
        do i = 2, count
            call field_real(result%out(i)%text, 10, energy_error, ios)
            largest = max(largest, abs(energy_error))
        end do
        call check(error, largest <= max_energy_error * (1 + 1.0e-5_wp), &
            "row energy errors within the summary maximum " // real_str(max_energy_error))
        ! (M, N) = (2, 1) has order 2M = 4: over a few steps the energy error is far below h**4.
        call check(error, max_energy_error > 0 .and. max_energy_error < h**4, &
            "small nonzero energy error: " // real_str(max_energy_error))
    end subroutine test_simulate_rows

    !> The number after `label` in the summary lines on standard error (-1 if none).
    function summary_value(result, label) result(value)
        type(command_result_t), intent(in) :: result !! a simulate run
        character(len=*), intent(in) :: label        !! text before the number
        real(wp) :: value
        integer :: i, at, ios
        value = -1
        do i = 1, size(result%err)
            at = index(result%err(i)%text, label)
            if (at == 0) cycle
            associate (rest => result%err(i)%text(at + len(label):))
                read (rest(:scan(rest // ",", ",") - 1), *, iostat=ios) value
            end associate
            if (ios /= 0) value = -1
            return
        end do
    end function summary_value

    !> --plain is a flag (a value is rejected) and gives the rows of the default (fast) run
    !! to round-off.
    subroutine test_simulate_plain(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: plain, fast
        integer :: i, k, ios
        real(wp) :: a, b, difference
        character(len=*), parameter :: options = "--system linkage --M 3 --h 1/4 --steps 8"

        call expect_rejection(error, "--plain=yes", ["--plain"])
        call simulate(error, options // " --plain", plain)
        call simulate(error, options, fast)
        if (allocated(error)) return
        call check(error, plain%exit_code == 0 .and. fast%exit_code == 0, "both runs succeed")
        call check(error, size(plain%out) == size(fast%out) .and. size(plain%out) == 10, &
            "rows: " // int_str(size(plain%out)) // " and " // int_str(size(fast%out)))
        if (allocated(error)) return
        difference = 0
        do i = 2, size(plain%out)
            do k = 1, 13   ! t, q (6), p (6)
                call field_real(plain%out(i)%text, k, a, ios)
                call field_real(fast%out(i)%text, k, b, ios)
                difference = max(difference, abs(a - b))
            end do
        end do
        call check(error, difference <= max(1.0e-30_wp, 1.0e4_wp * epsilon(1.0_wp)), &
            "--plain changes the state by " // real_str(difference))
        ! The plain path is taken: full Newton needs fewer iterations than simplified Newton.
        call check(error, any([(split_field(plain%out(i)%text, 21, ",") /= &
            split_field(fast%out(i)%text, 21, ","), i = 2, size(plain%out))]), &
            "--plain: the same Newton iterations as the fast path")
    end subroutine test_simulate_plain

    subroutine test_simulate_output_file(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: path
        integer :: ios

        path = scratch_path("cli_output.csv")
        call simulate(error, "--system linkage --M 3 --N 2 --G 4 --h 1/16 --steps 2 " // &
            "--output " // path, result)
        if (allocated(error)) return
        call check(error, result%exit_code == 0, "exit " // int_str(result%exit_code))
        call check(error, size(result%out) == 0, "nothing on standard output with --output")
        call check(error, file_exists(path), "the file is written")
        if (allocated(error)) return
        call read_lines(path, lines, ios)
        call check(error, size(lines) == 4, "header + rows at steps 0, 1, 2 in the file")
        if (size(lines) > 0) call check(error, index(lines(1)%text, "t,q1,q2,q3,q4,q5,q6,") == 1 &
            .and. index(lines(1)%text, ",lambda3,H,") > 0, "linkage header")
        if (size(lines) > 1) call check(error, field_count(lines(2)%text) == 21, "21 fields")
        ! An output file that cannot be opened is a failure of the run.
        call simulate(error, "--steps 1 --output " // scratch_path("no_such_dir/x.csv"), result)
        call check(error, result%exit_code == exit_failure .and. &
            any_line_contains(result%err, "cannot open --output"), "unwritable --output exits 1")
    end subroutine test_simulate_output_file

    subroutine test_simulate_failure(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        integer :: count
        ! M = N + 2 is singular on the pendulum (rotational symmetry): a run-time failure.
        call simulate(error, "--M 3 --N 1 --G 4 --steps 3", result)
        if (allocated(error)) return
        call check(error, result%exit_code == exit_failure, "integrator failure exits 1, got " &
            // int_str(result%exit_code))
        call check(error, size(result%out) == 1, "the header stays written")
        count = size(result%err)
        call check(error, count > 0, "a message on standard error")
        if (count > 0) call check(error, index(result%err(count)%text, &
            "holosym simulate: error: singular matrix") == 1, &
            "the last message reports the error: " // result%err(count)%text)
    end subroutine test_simulate_failure

end module test_cli
