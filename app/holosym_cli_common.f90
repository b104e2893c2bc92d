!> Shared pieces of the `holosym` command-line tool: the argument list, option splitting,
!! strict number parsing, CSV number formatting and the exit codes.
!!
!! Nothing here stops the program or prints: procedures return a `holosym_status_t`
!! (code `HOLOSYM_INVALID_ARGUMENT` and a message naming the option and the value), which
!! the commands report; only the main program turns exit codes into the process status.
module holosym_cli_common
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, int_str, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_output, only: output_t
    use holosym_decimal, only: read_decimal, number_ok, number_out_of_range
    implicit none
    private

    public :: cli_argument_t, command_arguments
    public :: split_option, option_value, parse_integer, parse_integer_in, parse_real
    public :: fail, csv_real, csv_integer, join_lines, parsed_command_proceeds, default_orders

    !> Exit code of a successful command.
    integer, parameter, public :: EXIT_OK = 0
    !> Exit code of a command that started but failed (integrator failure, I/O error).
    integer, parameter, public :: EXIT_FAILURE = 1
    !> Exit code of a usage error (unknown command or option, bad or missing value).
    integer, parameter, public :: EXIT_USAGE = 2

    !> Width of the CSV number field: sign, 36 significant digits, point, 'E', sign, 4 digits.
    integer, parameter :: csv_width = 48
    !> Format of a real CSV field: 36 significant digits round-trip a real128 exactly.
    character(len=*), parameter :: csv_format = '(es44.35e4)'
    !> Longest integer literal accepted (more digits always overflow the default integer).
    integer, parameter :: max_integer_digits = 18

    !> One command-line argument.
    type :: cli_argument_t
        !> The argument's text, without trailing blanks.
        character(len=:), allocatable :: text
    end type cli_argument_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The program's command-line arguments 1..n, from `get_command_argument`.
    function command_arguments() result(args)
        type(cli_argument_t), allocatable :: args(:) !! the arguments, in order
        integer :: i, length
        allocate (args(command_argument_count()))
        do i = 1, size(args)
            call get_command_argument(i, length=length)
            allocate (character(len=length) :: args(i)%text)
            if (length > 0) call get_command_argument(i, args(i)%text)
        end do
    end function command_arguments

    !> Split an argument into an option name and an inline value: "--h=0.5" gives name
    !! "--h", value "0.5"; "--h" gives name "--h" and no value.
    pure subroutine split_option(arg, name, value, has_value)
        character(len=*), intent(in) :: arg  !! the argument
        character(len=:), allocatable, intent(out) :: name  !! the option name
        character(len=:), allocatable, intent(out) :: value !! the inline value ("" if none)
        logical, intent(out) :: has_value    !! true for the form --name=value
        integer :: equals
        equals = 0
        if (len(arg) > 2) then
            if (arg(1:2) == "--") equals = index(arg, "=")
        end if
        has_value = equals > 0
        if (has_value) then
            name = arg(:equals - 1)
            value = arg(equals + 1:)
        else
            name = arg
            value = ""
        end if
    end subroutine split_option

    !> The value of option `name` at `args(position)`: the inline value if there is one,
    !! else the next argument (then `position` advances past it). Fails when no value follows
    !! and when the value is empty (`--name=` or `--name ""`): no option has an empty value.
    subroutine option_value(args, position, name, inline, has_inline, value, status)
        type(cli_argument_t), intent(in) :: args(:) !! all arguments of the command
        integer, intent(inout) :: position     !! index of the option; of its value on return
        character(len=*), intent(in) :: name   !! the option, for messages
        character(len=*), intent(in) :: inline !! inline value from `split_option`
        logical, intent(in) :: has_inline      !! whether the inline value was given
        character(len=:), allocatable, intent(out) :: value !! the value text
        type(holosym_status_t), intent(out) :: status !! failure names the option
        logical :: missing
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        if (has_inline) then
            value = inline
            missing = .false.
        else
            missing = position + 1 > size(args)
            if (.not. missing) missing = is_option_like(args(position + 1)%text)
            if (.not. missing) then
                position = position + 1
                value = args(position)%text
            end if
        end if
        if (missing) then
            value = ""
            call fail(status, "option " // name // " needs a value")
        else if (len(value) == 0) then
            call fail(status, "option " // name // " needs a value; got an empty one")
        end if
    end subroutine option_value

    !> True for "--anything" (not for "-1", which is a negative number).
    pure logical function is_option_like(text)
        character(len=*), intent(in) :: text !! an argument
        is_option_like = .false.
        if (len(text) >= 2) is_option_like = text(1:2) == "--"
    end function is_option_like

    !> Parse a decimal integer: optional sign and digits only. Fails with a message naming
    !! `name` and the text.
    subroutine parse_integer(name, text, value, status)
        character(len=*), intent(in) :: name  !! the option, for messages
        character(len=*), intent(in) :: text  !! the value text
        integer, intent(out) :: value         !! the integer
        type(holosym_status_t), intent(out) :: status !! failure names option and text
        integer :: first, ios
        value = 0
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        first = 1
        if (len(text) >= 1) then
            if (text(1:1) == "+" .or. text(1:1) == "-") first = 2
        end if
        if (len(text) < first .or. verify(text(first:), "0123456789") /= 0) then
            call fail(status, "option " // name // " expects an integer; got '" // text // "'")
            return
        end if
        ios = 1
        if (len(text) - first + 1 <= max_integer_digits) read (text, *, iostat=ios) value
        if (ios /= 0) then
            value = 0
            call fail(status, "option " // name // ": integer '" // text // "' is out of range")
        end if
    end subroutine parse_integer

    !> Parse a decimal integer in lower..upper: "option NAME must be in LOWER..UPPER; got
    !! 'TEXT'" otherwise (the text as given, never a converted value).
    subroutine parse_integer_in(name, text, lower, upper, value, status)
        character(len=*), intent(in) :: name  !! the option, for messages
        character(len=*), intent(in) :: text  !! the value text
        integer, intent(in) :: lower, upper   !! the documented range
        integer, intent(out) :: value         !! the integer
        type(holosym_status_t), intent(out) :: status !! failure names option and text
        call parse_integer(name, text, value, status)
        if (status%ok()) then
            if (value < lower .or. value > upper) then
                value = 0
                call fail(status, "option " // name // " must be in " // int_str(lower) // &
                    ".." // int_str(upper) // "; got '" // text // "'")
            end if
        else if (index(status%message, "out of range") > 0) then
            call fail(status, "option " // name // " must be in " // int_str(lower) // ".." // &
                int_str(upper) // "; got '" // text // "'")
        end if
    end subroutine parse_integer_in

    !> Parse a real: a decimal number such as `0.0625`, `1e-3`, `-2.5D0`, or a quotient of two
    !! such numbers such as `1/8`. NaN, Inf and anything else fail with a message naming `name`;
    !! so do nonzero numbers and quotients whose magnitude is not in [1e-R, 1e+R) (R =
    !! range(1.0_wp): 4931 in real128, 307 in real64): "out of range". No conversion ever
    !! overflows.
    subroutine parse_real(name, text, value, status)
        character(len=*), intent(in) :: name  !! the option, for messages
        character(len=*), intent(in) :: text  !! the value text
        real(wp), intent(out) :: value        !! the number
        type(holosym_status_t), intent(out) :: status !! failure names option and text
        real(wp) :: numerator, denominator
        integer :: slash, outcome, outcome2
        value = 0
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        slash = index(text, "/")
        if (slash > 0) then
            call read_decimal(text(:slash - 1), numerator, outcome)
            outcome2 = number_ok
            if (outcome == number_ok) call read_decimal(text(slash + 1:), denominator, outcome2)
            if (outcome == number_ok .and. outcome2 /= number_ok) outcome = outcome2
            if (outcome == number_ok) then
                if (denominator == 0) then
                    call fail(status, "option " // name // ": division by zero in '" // &
                        text // "'")
                    return
                end if
                if (.not. quotient_in_range(numerator, denominator)) then
                    outcome = number_out_of_range
                else
                    value = numerator / denominator
                    if (value /= 0 .and. (abs(value) < 10.0_wp**(-range(1.0_wp)) .or. &
                        abs(value) >= 10.0_wp**range(1.0_wp))) outcome = number_out_of_range
                end if
            end if
        else
            call read_decimal(text, value, outcome)
        end if
        select case (outcome)
        case (number_ok)
        case (number_out_of_range)
            value = 0
            call fail(status, "option " // name // ": '" // text // "' is out of range " // &
                "(magnitudes from 1e-" // int_str(range(1.0_wp)) // " to 1e+" // &
                int_str(range(1.0_wp)) // ", or 0)")
        case default
            value = 0
            call fail(status, "option " // name // " expects a number (e.g. 0.0625, 1e-3 or " &
                // "1/16); got '" // text // "'")
        end select
    end subroutine parse_real

    !> Whether numerator / denominator (finite, denominator nonzero) has a magnitude in
    !! 1e-R .. 1e+R or is 0, decided on the binary exponents before dividing.
    pure logical function quotient_in_range(numerator, denominator) result(ok)
        real(wp), intent(in) :: numerator, denominator
        integer :: binary
        ok = .true.
        if (numerator == 0) return
        binary = exponent(numerator) - exponent(denominator)
        ! |n / d| lies in 2**(binary - 1) .. 2**(binary + 1).
        ok = binary + 1 <= floor(range(1.0_wp) * log(10.0) / log(2.0)) .and. &
            binary - 1 >= -floor(range(1.0_wp) * log(10.0) / log(2.0))
    end function quotient_in_range

    !> Set a usage failure (code HOLOSYM_INVALID_ARGUMENT) with `message`.
    pure subroutine fail(status, message)
        type(holosym_status_t), intent(inout) :: status !! the status to set
        character(len=*), intent(in) :: message         !! what was wrong, naming the value
        status%code = HOLOSYM_INVALID_ARGUMENT
        status%message = message
    end subroutine fail

    !> The orders not given on the command line, N = M - 1 and G = max(M, N) + 1, then
    !! G >= N + 1 checked (the step is singular for every system otherwise), the message
    !! naming the defaults taken.
    pure subroutine default_orders(order_m, order_n, gauss_points, n_given, g_given, status)
        integer, intent(in) :: order_m                  !! M
        integer, intent(inout) :: order_n               !! N (set unless given)
        integer, intent(inout) :: gauss_points          !! G (set unless given)
        logical, intent(in) :: n_given, g_given         !! whether --N and --G were given
        type(holosym_status_t), intent(inout) :: status !! set on failure
        if (.not. n_given) order_n = order_m - 1
        if (.not. g_given) gauss_points = max(order_m, order_n) + 1
        if (gauss_points >= order_n + 1) return
        if (n_given) then
            call fail(status, "options --G and --N: G = " // int_str(gauss_points) // &
                " must be at least N + 1 = " // int_str(order_n + 1))
        else
            call fail(status, "option --G: G = " // int_str(gauss_points) // &
                " must be at least N + 1 = " // int_str(order_n + 1) // &
                " (N is M - 1 when --N is not given)")
        end if
    end subroutine default_orders

    !> A real as a CSV field: scientific notation with 36 significant digits (exact for
    !! real128), no blanks, e.g. "-3.33333333333333333333333333333333317E-0001".
    function csv_real(value) result(field)
        real(wp), intent(in) :: value !! the number
        character(len=:), allocatable :: field !! its text
        character(len=csv_width) :: buffer
        write (buffer, csv_format) value
        field = trim(adjustl(buffer))
    end function csv_real

    !> An integer as a CSV field, no blanks.
    pure function csv_integer(value) result(field)
        integer, intent(in) :: value !! the number
        character(len=:), allocatable :: field !! its text
        character(len=csv_width) :: buffer
        write (buffer, '(i0)') value
        field = trim(buffer)
    end function csv_integer

    !> Join lines with newlines, for help texts written with one `write`.
    pure function join_lines(lines) result(text)
        character(len=*), intent(in) :: lines(:) !! lines (trailing blanks are trimmed)
        character(len=:), allocatable :: text    !! the joined text
        integer :: i
        text = ""
        do i = 1, size(lines)
            if (i > 1) text = text // new_line("a")
            text = text // trim(lines(i))
        end do
    end function join_lines

    !> After parsing a command's options: on a parse failure write the message and a hint to
    !! `err_unit` (exit 2); with --help write the help to `out` (exit 0). True when the
    !! command should go on and run.
    logical function parsed_command_proceeds(command, status, help, help_text, out, &
                                             err_unit, exit_code) result(proceed)
        character(len=*), intent(in) :: command   !! the command's name, for messages
        type(holosym_status_t), intent(in) :: status !! outcome of the option parser
        logical, intent(in) :: help               !! --help was given
        character(len=*), intent(in) :: help_text !! the command's help
        type(output_t), intent(inout) :: out      !! output for the help
        integer, intent(in) :: err_unit           !! unit for the error
        integer, intent(out) :: exit_code         !! EXIT_USAGE, EXIT_OK, or EXIT_OK to go on
        proceed = .false.
        exit_code = EXIT_OK
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym " // command // ": " // status%message
            write (err_unit, '(a)') "Run 'holosym " // command // " --help' for the options."
            exit_code = EXIT_USAGE
        else if (help) then
            call out%line(help_text)
        else
            proceed = .true.
        end if
    end function parsed_command_proceeds

end module holosym_cli_common

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_common) holosym_cli_common_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_common_app
