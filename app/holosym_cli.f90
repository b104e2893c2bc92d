!> The dispatcher of the `holosym` command-line tool: `holosym COMMAND [options]`.
!!
!! Each command lives in its own module `holosym_cli_NAME` with a procedure
!! `NAME_command(args, out_unit, err_unit, exit_code)` and a `NAME_help()` text. To add a
!! command (e.g. `tables`, `extremes`, `bench`), write that module, add one `case` to
!! `run_command` and one line to `cli_help`. Nothing here stops the program: the main
!! program turns `exit_code` into the process exit status.
module holosym_cli
    use holosym_release, only: holosym_version
    use holosym_kinds, only: wp
    use holosym_cli_common, only: cli_argument_t, join_lines, EXIT_OK, EXIT_USAGE
    use holosym_cli_simulate, only: simulate_command
    use holosym_cli_tables, only: tables_command
    use holosym_cli_bench, only: bench_command
    use holosym_cli_extremes, only: extremes_command
    use holosym_cli_ensemble, only: ensemble_command
    use holosym_task_farm, only: task_farm
    use holosym_cli_figures, only: figures_command
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
            "  figures    the data of the figures in docs/figures.md, as CSV", &
            "", &
            "Run 'holosym COMMAND --help' (or 'holosym help COMMAND') for a command's options.", &
            "'holosym --version' prints the version.", &
            "Exit status: 0 success, 1 the command failed, 2 bad usage."])
    end function cli_help

    !> Run the command line `args` (without the program name). Output goes to `out_unit`,
    !! messages to `err_unit`; `exit_code` is 0 on success, 1 when a command failed and
    !! 2 on a usage error (no or unknown command, bad options). `farm` (the MPI build's)
    !! computes the tasks of `ensemble` and `tables`; without it they run on threads.
    subroutine cli_run(args, out_unit, err_unit, exit_code, farm)
        type(cli_argument_t), intent(in) :: args(:) !! command-line arguments
        integer, intent(in) :: out_unit   !! unit for results and help
        integer, intent(in) :: err_unit   !! unit for progress and errors
        integer, intent(out) :: exit_code !! process exit code
        class(task_farm), intent(inout), optional :: farm !! who computes farmed tasks

        if (size(args) == 0) then
            write (err_unit, '(a)') cli_help()
            exit_code = EXIT_USAGE
            return
        end if
        select case (args(1)%text)
        case ("-h", "--help")
            write (out_unit, '(a)') cli_help()
            exit_code = EXIT_OK
        case ("-V", "--version")
            write (out_unit, '(a, i0, a)') "holosym " // holosym_version // &
                " (working precision: ", storage_size(1.0_wp), "-bit real)"
            exit_code = EXIT_OK
        case ("help")
            if (size(args) == 1) then
                write (out_unit, '(a)') cli_help()
                exit_code = EXIT_OK
            else
                call run_command(args(2)%text, [cli_argument_t("--help")], out_unit, &
                                 err_unit, exit_code, farm)
            end if
        case default
            call run_command(args(1)%text, args(2:), out_unit, err_unit, exit_code, farm)
        end select
    end subroutine cli_run

    !> Dispatch to the command called `name` with its arguments.
    subroutine run_command(name, args, out_unit, err_unit, exit_code, farm)
        character(len=*), intent(in) :: name        !! the command
        type(cli_argument_t), intent(in) :: args(:) !! its arguments
        integer, intent(in) :: out_unit   !! unit for results and help
        integer, intent(in) :: err_unit   !! unit for progress and errors
        integer, intent(out) :: exit_code !! process exit code
        class(task_farm), intent(inout), optional :: farm !! who computes farmed tasks
        select case (name)
        case ("simulate")
            call simulate_command(args, out_unit, err_unit, exit_code)
        case ("tables")
            call tables_command(args, out_unit, err_unit, exit_code, farm)
        case ("bench")
            call bench_command(args, out_unit, err_unit, exit_code)
        case ("extremes")
            call extremes_command(args, out_unit, err_unit, exit_code)
        case ("ensemble")
            call ensemble_command(args, out_unit, err_unit, exit_code, farm)
        case ("figures")
            call figures_command(args, out_unit, err_unit, exit_code)
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
