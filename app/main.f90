!> The `holosym` command-line tool: `holosym COMMAND [options]`; see `holosym --help`.
!! All work is done by `cli_run`; this program only passes the arguments and turns the
!! exit code into the process exit status (silently: messages were already written).
program holosym_main
    use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
    use holosym_cli, only: cli_run
    use holosym_cli_common, only: command_arguments
    implicit none
    integer :: exit_code

    call cli_run(command_arguments(), output_unit, error_unit, exit_code)
    if (exit_code /= 0) stop exit_code, quiet=.true.
end program holosym_main
