!> The `lyapunov` command of the `holosym` tool: the Lyapunov spectrum and MEGNO of one
!! orbit of a system on its constraint manifold, as CSV rows t,lambda1..lambdak,megno
!! every so many steps (the finite-time values up to t), from the library's
!! `lyapunov_tracker_t`; the final values and the time taken on standard error.
module holosym_cli_lyapunov
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, status_code_name, int_str, real_str, &
        append_numbered, HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_lyapunov, only: lyapunov_tracker_t, lyapunov_result_t
    use holosym_systems, only: system_source_t, make_source_system
    use holosym_ensemble_files, only: seconds_text
    use holosym_cli_common, only: parsed_command_proceeds, cli_argument_t, split_option, &
        option_value, parse_integer_in, fail, csv_real, join_lines, default_orders, EXIT_OK, &
        EXIT_FAILURE
    use holosym_cli_ensemble, only: ensemble_config_t, system_options_help, take_run_option, &
        steps_fit
    use holosym_output, only: output_t, open_output
    implicit none
    private

    public :: lyapunov_command, lyapunov_help

    !> Default --T: long enough for a chaotic pendulum's largest exponent to show.
    real(wp), parameter :: default_span = 100
    !> Rows written by default: one every tenth of the run (and the last).
    integer, parameter :: default_rows = 10

    !> Options of `holosym lyapunov`: the system, the scheme, h, T and the output (shared
    !! with `ensemble`), and the row stride.
    type :: lyapunov_config_t
        type(ensemble_config_t) :: run  !! the shared options (T default 100)
        integer :: every = 0            !! a row every `every` steps (0: a tenth of the run)
    end type lyapunov_config_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym lyapunov --help`.
    pure function lyapunov_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym lyapunov [options]", &
            "", &
            "The Lyapunov spectrum and MEGNO of the orbit from the system's initial state,", &
            "on its constraint manifold (docs/events.md): a basis of the manifold's tangent", &
            "space carried by the tangent map of every step and re-orthonormalised", &
            "(Benettin), 2(n - m) exponents in pairs +-lambda; MEGNO tends to 2 on a", &
            "regular orbit and grows like lambda t / 2 on a chaotic one. Writes CSV rows", &
            "t,lambda1..lambdak,megno (the finite-time values up to t, largest exponent", &
            "first; megno the mean MEGNO <Y>) every --every steps and after the last.", &
            "", &
            "Options:", &
            system_options_help(), &
            "  --h REAL        step size                                    [0.0625]", &
            "  --T REAL        final time                                   [100]", &
            "  --every K       a row every K steps, 1..2147483647           [a tenth of T/h]", &
            "  --output FILE   the CSV                                      [standard output]", &
            "  --quiet         no start and summary lines", &
            "  -h, --help      show this help", &
            "", &
            "Exit status: 0 success; 1 a step failed (the rows before it are kept), bad", &
            "input or an I/O failure; 2 bad usage.", &
            "", &
            "Example:", &
            "  holosym lyapunov --system double --M 4 --h 1/16 --T 50"])
    end function lyapunov_help

    !> Run `holosym lyapunov` with its arguments.
    subroutine lyapunov_command(args, out, err_unit, exit_code)
        type(cli_argument_t), intent(in) :: args(:) !! arguments after "lyapunov"
        type(output_t), intent(inout) :: out !! the help and, without --output, the CSV
        integer, intent(in) :: err_unit   !! unit for messages
        integer, intent(out) :: exit_code !! process exit code
        type(lyapunov_config_t) :: config
        type(holosym_status_t) :: status
        call parse_lyapunov_options(args, config, status)
        if (.not. parsed_command_proceeds("lyapunov", status, config%run%help, &
                                          lyapunov_help(), out, err_unit, exit_code)) return
        call run_lyapunov_command(config, out, err_unit, exit_code)
    end subroutine lyapunov_command

    !> Parse the options of `lyapunov`. Failure: HOLOSYM_INVALID_ARGUMENT naming the option.
    subroutine parse_lyapunov_options(args, config, status)
        type(cli_argument_t), intent(in) :: args(:)
        type(lyapunov_config_t), intent(out) :: config
        type(holosym_status_t), intent(out) :: status
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline, n_given, g_given, taken
        integer :: i
        config%run%output = ""
        config%run%final_time = default_span
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        n_given = .false.
        g_given = .false.
        i = 1
        do while (i <= size(args))
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                config%run%help = .true.
                return
            case ("--quiet")
                if (has_inline) then
                    call fail(status, "option --quiet takes no value")
                    return
                end if
                config%run%quiet = .true.
            case ("--system", "--model", "--set", "--links", "--M", "--N", "--G", "--h", &
                  "--T", "--output", "--every")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                call config%run%source%take(name, value, taken, status)
                if (status%ok() .and. .not. taken .and. name == "--every") then
                    call parse_integer_in(name, value, 1, huge(1), config%every, status)
                    taken = .true.
                end if
                if (status%ok() .and. .not. taken) call take_run_option(name, value, &
                    config%run, taken, n_given, g_given, status)
                if (.not. status%ok()) return
            case default
                call fail(status, "unknown option '" // args(i)%text // "'")
                return
            end select
            i = i + 1
        end do
        call config%run%source%check(status)
        if (status%ok()) call default_orders(config%run%order_m, config%run%order_n, &
                                             config%run%gauss_points, n_given, g_given, status)
        if (status%ok() .and. .not. (config%run%final_time > 0 .and. &
                                     steps_fit(config%run%final_time, config%run%step_size))) &
            call fail(status, "options --T and --h: T must be > 0 and T/h give 1 to " // &
                      int_str(huge(1)) // " steps")
    end subroutine parse_lyapunov_options

    !> Run a parsed `lyapunov` command.
    subroutine run_lyapunov_command(config, out, err_unit, exit_code)
        type(lyapunov_config_t), intent(in) :: config
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        integer, intent(out) :: exit_code
        class(constrained_hamiltonian), allocatable, target :: sys
        type(constrained_integrator) :: integ
        type(lyapunov_tracker_t) :: tracker
        type(lyapunov_result_t) :: result
        type(output_t) :: file
        type(holosym_status_t) :: status, closing
        real(wp), allocatable :: q(:), p(:)
        character(len=:), allocatable :: note
        integer(int64) :: clock_start, clock_end, clock_rate
        integer :: steps, every, done
        exit_code = EXIT_FAILURE
        call system_clock(clock_start, clock_rate)
        call make_source_system(config%run%source, sys, q, p, status, note)
        if (status%ok() .and. len(note) > 0 .and. .not. config%run%quiet) &
            write (err_unit, '(a)') "holosym lyapunov: note: " // note
        if (status%ok()) call integ%init(sys, config%run%order_m, config%run%order_n, &
                                         config%run%gauss_points, status)
        if (status%ok()) call tracker%start(sys, q, p, status)
        if (status%ok() .and. len(config%run%output) > 0) &
            call open_output(config%run%output, file, status)
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym lyapunov: error: " // status%message
            return
        end if
        steps = nint(config%run%final_time / config%run%step_size)
        every = config%every
        if (every == 0) every = max(1, steps / default_rows)
        if (.not. config%run%quiet) write (err_unit, '(a)') "holosym lyapunov: " // &
            config%run%source%label() // " (n = " // int_str(sys%n) // ", m = " // &
            int_str(sys%m) // "), (M, N, G) = (" // int_str(config%run%order_m) // ", " // &
            int_str(config%run%order_n) // ", " // int_str(config%run%gauss_points) // &
            "), " // int_str(steps) // " steps of h = " // real_str(config%run%step_size)
        call put_line(header(2 * (sys%n - sys%m)))
        done = 0
        do while (done < steps .and. status%ok())
            call tracker%advance(integ, sys, q, p, config%run%step_size, &
                                 min(every, steps - done), status)
            result = tracker%result()
            done = result%steps
            if (done > 0) call put_line(row(result))
        end do
        if (len(config%run%output) > 0) then
            call file%close(closing)
            if (.not. closing%ok()) then
                write (err_unit, '(a)') "holosym lyapunov: error: " // closing%message
                return
            end if
        end if
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym lyapunov: error after " // int_str(done) // &
                " steps (rows kept): " // status_code_name(status%code) // ": " // &
                status%message
            return
        end if
        call system_clock(clock_end)
        if (.not. config%run%quiet) call summary(result, &
            real(clock_end - clock_start, wp) / clock_rate)
        exit_code = EXIT_OK
    contains
        subroutine put_line(text)
            character(len=*), intent(in) :: text
            if (len(config%run%output) > 0) then
                call file%line(text)
            else
                call out%line(text)
            end if
        end subroutine put_line
        subroutine summary(result, seconds)
            type(lyapunov_result_t), intent(in) :: result
            real(wp), intent(in) :: seconds
            character(len=:), allocatable :: text
            integer :: k
            text = "holosym lyapunov: T = " // real_str(result%time) // ": exponents"
            do k = 1, size(result%exponents)
                text = text // " " // real_str(result%exponents(k))
            end do
            write (err_unit, '(a)') text // ", MEGNO " // real_str(result%megno) // " in " // &
                seconds_text(seconds, '(f0.2)') // " s"
        end subroutine summary
    end subroutine run_lyapunov_command

    !> "t,lambda1,...,lambdak,megno".
    function header(count) result(text)
        integer, intent(in) :: count
        character(len=:), allocatable :: text
        text = "t,"
        call append_numbered(text, "lambda", count, ",")
        text = text // ",megno"
    end function header

    !> One CSV row of a result.
    function row(result) result(text)
        type(lyapunov_result_t), intent(in) :: result
        character(len=:), allocatable :: text
        integer :: k
        text = csv_real(result%time)
        do k = 1, size(result%exponents)
            text = text // "," // csv_real(result%exponents(k))
        end do
        text = text // "," // csv_real(result%megno)
    end function row

end module holosym_cli_lyapunov

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_lyapunov) holosym_cli_lyapunov_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_lyapunov_app
