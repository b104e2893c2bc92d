!> The `holosym` command-line tool: `holosym COMMAND [options]`; see `holosym --help`.
!! All work is done by `cli_run`; this program only passes the arguments and turns the
!! exit code into the process exit status (silently: messages were already written).
!! Results go to standard output through `holosym_output` (failed writes are errors).
program holosym_main
    use, intrinsic :: iso_fortran_env, only: error_unit
    use holosym_cli, only: cli_run
    use holosym_cli_common, only: command_arguments
    use holosym_output, only: keep_standard_streams
    implicit none
    integer :: exit_code

    ! A closed standard output or error must make writes fail, not go to a file.
    call keep_standard_streams()
    call cli_run(command_arguments(), error_unit, exit_code)
    if (exit_code /= 0) stop exit_code, quiet=.true.
end program holosym_main
