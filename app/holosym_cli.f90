!> The dispatcher of the `holosym` command-line tool: `holosym COMMAND [options]`.
!!
!! Each command lives in its own module `holosym_cli_NAME` with a procedure
!! `NAME_command(args, out, err_unit, exit_code)` and a `NAME_help()` text. To add a
!! command (e.g. `tables`, `extremes`, `bench`), write that module, add one `case` to
!! `run_command` and one line to `cli_help`. Nothing here stops the program: the main
!! program turns `exit_code` into the process exit status.
module holosym_cli
    use holosym_release, only: holosym_version
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, int_str
    use holosym_output, only: output_t, standard_output, open_output
    use holosym_cli_common, only: cli_argument_t, join_lines, EXIT_OK, EXIT_USAGE, EXIT_FAILURE
    use holosym_cli_simulate, only: simulate_command
    use holosym_cli_tables, only: tables_command
    use holosym_cli_bench, only: bench_command
    use holosym_cli_extremes, only: extremes_command
    use holosym_cli_ensemble, only: ensemble_command
    use holosym_cli_poincare, only: poincare_command
    use holosym_cli_lyapunov, only: lyapunov_command
    use holosym_task_farm, only: task_farm
    use holosym_cli_figures, only: figures_command
    use holosym_cli_check, only: check_command
    implicit none
    private

    public :: cli_run, cli_help

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym --help`.
    pure function cli_help() result(text)
        character(len=:), allocatable :: text !! the help, lines joined by newlines
        text = join_lines([character(len=96) :: &
            "Usage: holosym COMMAND [options]", &
            "", &
            "Symplectic integration of Hamiltonian systems with holonomic constraints", &
            "in quadruple precision.", &
            "", &
            "Commands:", &
            "  simulate   integrate a system and write its trajectory as CSV", &
            "  tables     measure the paper's Tables 1-2 and the minimum Gauss points", &
            "  bench      work-precision benchmark against composed RATTLE; speed options", &
            "  extremes   stability at the extremes: long runs, tiny/large steps, high orders", &
            "  ensemble   many trajectories in parallel (threads or MPI ranks), resumable", &
            "  poincare   the crossings of a section g(q, p) = 0 by orbits (Poincare sections)", &
            "  lyapunov   the Lyapunov spectrum and MEGNO of an orbit on the manifold", &
            "  figures    the data of the figures in docs/figures.md, as CSV", &
            "  check      compare a system's procedures and declarations with each other", &
            "", &
            "Run 'holosym COMMAND --help' (or 'holosym help COMMAND') for a command's options.", &
            "'holosym --version' prints the version.", &
            "Exit status: 0 success, 1 the command failed, 2 bad usage."])
    end function cli_help

    !> Run the command line `args` (without the program name). Results and help go to
    !! standard output (with `quiet`, nowhere: the MPI ranks that do not collect),
    !! messages to `err_unit`; `exit_code` is 0 on success, 1 when a command failed (also
    !! when its results could not be written) and 2 on a usage error (no or unknown
    !! command, bad options). `farm` (the MPI build's) computes the tasks of `ensemble` and
    !! `tables`; without it they run on threads.
    subroutine cli_run(args, err_unit, exit_code, farm, quiet)
        type(cli_argument_t), intent(in) :: args(:) !! command-line arguments
        integer, intent(in) :: err_unit   !! unit for progress and errors
        integer, intent(out) :: exit_code !! process exit code
        class(task_farm), intent(inout), optional :: farm !! who computes farmed tasks
        logical, intent(in), optional :: quiet !! discard the results (not the messages)
        type(output_t) :: out
        type(holosym_status_t) :: status
        character(len=:), allocatable :: name
        logical :: discard

        discard = .false.
        if (present(quiet)) discard = quiet
        if (discard) then
            call open_output("/dev/null", out, status)
        else
            out = standard_output()
        end if
        name = "holosym"
        if (size(args) == 0) then
            write (err_unit, '(a)') cli_help()
            exit_code = EXIT_USAGE
            return
        end if
        select case (args(1)%text)
        case ("-h", "--help")
            call out%line(cli_help())
            exit_code = EXIT_OK
        case ("-V", "--version")
            call out%line("holosym " // holosym_version // " (working precision: " // &
                int_str(storage_size(1.0_wp)) // "-bit real)")
            exit_code = EXIT_OK
        case ("help")
            if (size(args) == 1) then
                call out%line(cli_help())
                exit_code = EXIT_OK
            else
                name = "holosym " // args(2)%text
                call run_command(args(2)%text, [cli_argument_t("--help")], out, err_unit, &
                                 exit_code, farm)
            end if
        case default
            name = "holosym " // args(1)%text
            call run_command(args(1)%text, args(2:), out, err_unit, exit_code, farm)
        end select
        ! A command that succeeded fails when its output could not be written.
        call out%close(status)
        if (.not. status%ok() .and. exit_code == EXIT_OK) then
            write (err_unit, '(a)') name // ": error: " // status%message
            exit_code = EXIT_FAILURE
        end if
    end subroutine cli_run

    !> Dispatch to the command called `name` with its arguments.
    subroutine run_command(name, args, out, err_unit, exit_code, farm)
        character(len=*), intent(in) :: name        !! the command
        type(cli_argument_t), intent(in) :: args(:) !! its arguments
        type(output_t), intent(inout) :: out   !! results and help
        class(task_farm), intent(inout), optional :: farm !! who computes farmed tasks
        integer, intent(in) :: err_unit   !! unit for progress and errors
        integer, intent(out) :: exit_code !! process exit code
        select case (name)
        case ("simulate")
            call simulate_command(args, out, err_unit, exit_code)
        case ("tables")
            call tables_command(args, out, err_unit, exit_code, farm)
        case ("bench")
            call bench_command(args, out, err_unit, exit_code)
        case ("extremes")
            call extremes_command(args, out, err_unit, exit_code)
        case ("check")
            call check_command(args, out, err_unit, exit_code)
        case ("ensemble")
            call ensemble_command(args, out, err_unit, exit_code, farm)
        case ("poincare")
            call poincare_command(args, out, err_unit, exit_code, farm)
        case ("lyapunov")
            call lyapunov_command(args, out, err_unit, exit_code)
        case ("figures")
            call figures_command(args, out, err_unit, exit_code)
        case default
            write (err_unit, '(a)') "holosym: unknown command '" // name // &
                "'; run 'holosym --help' for the list of commands"
            exit_code = EXIT_USAGE
        end select
    end subroutine run_command

end module holosym_cli

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli) holosym_cli_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_app
