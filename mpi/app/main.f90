!> `holosym-mpi`: the `ensemble`, `poincare` and `tables` commands of the holosym tool
!! with their tasks spread over MPI ranks (`mpirun -np P holosym-mpi ensemble ...`); the
!! same options and the same output files as `holosym`. Rank 0 writes every output; the other ranks discard
!! their results (`cli_run`'s `quiet`) and their messages go to /dev/null. Other
!! commands: use `holosym`.
program holosym_mpi_main
    use, intrinsic :: iso_fortran_env, only: error_unit
    use mpi_f08, only: MPI_Init_thread, MPI_Finalize, MPI_Abort, MPI_Comm_rank, &
        MPI_COMM_WORLD, MPI_THREAD_FUNNELED
    use holosym_cli, only: cli_run
    use holosym_cli_common, only: command_arguments, cli_argument_t
    use holosym_mpi_farm, only: mpi_farm
    use holosym_output, only: keep_standard_streams
    implicit none
    type(mpi_farm) :: farm
    type(cli_argument_t), allocatable :: args(:)
    integer :: provided, rank, exit_code, err_unit

    call MPI_Init_thread(MPI_THREAD_FUNNELED, provided)
    call MPI_Comm_rank(MPI_COMM_WORLD, rank)
    if (provided < MPI_THREAD_FUNNELED) then
        if (rank == 0) write (error_unit, '(a)') "holosym-mpi: the MPI library does not " // &
            "provide MPI_THREAD_FUNNELED"
        call MPI_Abort(MPI_COMM_WORLD, 1)
    end if
    ! A closed standard output must make writes fail, not go to a file (as in holosym).
    call keep_standard_streams()
    err_unit = error_unit
    if (rank /= 0) open (newunit=err_unit, file="/dev/null", action="write")
    args = command_arguments()
    exit_code = 0
    if (size(args) >= 1) then
        select case (args(1)%text)
        case ("ensemble", "tables", "poincare", "help", "-h", "--help")
        case default
            write (err_unit, '(a)') "holosym-mpi: runs 'ensemble', 'poincare' and 'tables' " // &
                "on MPI ranks;" &
                // " for '" // args(1)%text // "' use holosym"
            exit_code = 2
        end select
    end if
    if (exit_code == 0) call cli_run(args, err_unit, exit_code, farm, quiet=rank /= 0)
    call MPI_Finalize()
    if (exit_code /= 0) stop exit_code, quiet=.true.
end program holosym_mpi_main
