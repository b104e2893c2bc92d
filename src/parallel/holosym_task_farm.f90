!> A task farm: independent numbered tasks computed by several workers, each result handed
!! to one collector. The ensemble driver and the `tables` cells are written against it, so
!! that the same job runs serially, on OpenMP threads (`openmp_farm`, here) or on MPI ranks
!! (`mpi_farm` of the separate holosym-mpi package) without change.
!!
!! A job extends `farm_job` with two bindings:
!! - `run(task, record)` computes one task and returns its result as a record (bytes, see
!!   holosym_records). It may run on any worker, concurrently with other tasks, so it must
!!   not change the job (intent(in)) nor any shared state.
!! - `accept(task, record, halt)` receives each record on the collector, one at a time, in
!!   the order in which the tasks complete; it may write files and set `halt` to stop
!!   handing out tasks.
!! Results depend only on the task number, never on which worker ran it or when: that is
!! what makes the output of every farm identical.
module holosym_task_farm
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_USER_ABORT, HOLOSYM_INVALID_ARGUMENT
    implicit none
    private

    public :: farm_job, task_farm, openmp_farm

    !> Work to be farmed out: extend it and keep the job's data as components.
    type, abstract :: farm_job
    contains
        !> Compute task `task` into `record` (any worker, concurrently).
        procedure(job_run_interface), deferred :: run
        !> Receive the record of `task` (the collector, one at a time).
        procedure(job_accept_interface), deferred :: accept
    end type farm_job

    abstract interface
        subroutine job_run_interface(self, task, record)
            import :: farm_job
            class(farm_job), intent(in) :: self !! the job
            integer, intent(in) :: task         !! task number
            character(len=:), allocatable, intent(out) :: record !! its result, as bytes
        end subroutine job_run_interface

        subroutine job_accept_interface(self, task, record, halt)
            import :: farm_job
            class(farm_job), intent(inout) :: self !! the job
            integer, intent(in) :: task            !! task number
            character(len=*), intent(in) :: record !! its result from `run`
            logical, intent(inout) :: halt         !! set .true. to hand out no more tasks
        end subroutine job_accept_interface
    end interface

    !> Who computes the tasks. `execute` is called by every process of the farm with the
    !! same job; only the collector's `accept` is called.
    type, abstract :: task_farm
    contains
        !> Run the listed tasks of `job`.
        procedure(farm_execute_interface), deferred :: execute
        !> Whether this process is the collector (the one that receives every record).
        procedure :: is_collector => single_process_collector
        !> `ok` on every process of the farm (a logical AND across processes): lets all of
        !! them agree before a collective `execute`.
        procedure :: agree => single_process_agree
        !> Number of processes of the farm (1 without MPI).
        procedure :: processes => single_process_count
    end type task_farm

    abstract interface
        subroutine farm_execute_interface(self, job, tasks, status)
            import :: task_farm, farm_job, holosym_status_t
            class(task_farm), intent(inout) :: self !! the farm
            class(farm_job), intent(inout) :: job   !! the work
            !> Task numbers to run, in the order they are handed out (read on the collector).
            integer, intent(in) :: tasks(:)
            type(holosym_status_t), intent(out) :: status !! HOLOSYM_USER_ABORT when halted
        end subroutine farm_execute_interface
    end interface

    !> Tasks on the threads of this process, dynamically scheduled one at a time (tasks
    !! differ in cost); `accept` runs in a critical section. Without OpenMP, serial.
    type, extends(task_farm) :: openmp_farm
        !> Threads to use; 0 for the OpenMP default (OMP_NUM_THREADS).
        integer :: threads = 0
    contains
        procedure :: execute => openmp_execute
    end type openmp_farm

contains

    !> A farm within one process: it is the collector.
    logical function single_process_collector(self) result(collector)
        class(task_farm), intent(in) :: self !! the farm
        collector = .true.
    end function single_process_collector

    !> A farm within one process: `ok` itself.
    logical function single_process_agree(self, ok) result(all_ok)
        class(task_farm), intent(inout) :: self !! the farm
        logical, intent(in) :: ok !! this process's verdict
        all_ok = ok
    end function single_process_agree

    !> A farm within one process: 1.
    integer function single_process_count(self) result(count)
        class(task_farm), intent(in) :: self !! the farm
        count = 1
    end function single_process_count

    !> Run the tasks on OpenMP threads. Fails with HOLOSYM_INVALID_ARGUMENT for a negative
    !! thread count, HOLOSYM_USER_ABORT when `accept` halted the run (tasks in progress are
    !! finished but not accepted).
    subroutine openmp_execute(self, job, tasks, status)
        class(openmp_farm), intent(inout) :: self !! the farm
        class(farm_job), intent(inout) :: job     !! the work
        integer, intent(in) :: tasks(:)           !! task numbers, in order
        type(holosym_status_t), intent(out) :: status !! outcome
        logical :: halted
        integer :: i, accepted, threads

        if (self%threads < 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "threads must be >= 0; got " &
                // int_str(self%threads))
            return
        end if
        threads = self%threads
        halted = .false.
        accepted = 0
        !$ if (threads == 0) threads = omp_default_threads()
        !$omp parallel do schedule(dynamic, 1) num_threads(max(threads, 1)) default(shared) &
        !$omp private(i)
        do i = 1, size(tasks)
            call run_and_accept(job, tasks(i), halted, accepted)
        end do
        !$omp end parallel do
        if (halted) then
            call set_status(status, HOLOSYM_USER_ABORT, "the collector stopped the run after " &
                // int_str(accepted) // " of " // int_str(size(tasks)) // " tasks")
        else
            call set_status(status, HOLOSYM_SUCCESS, "")
        end if
    end subroutine openmp_execute

    !> One task on the calling thread: run it unless the run was halted, then accept its
    !! record in the critical section (its own procedure, so that the record is local to
    !! the thread).
    subroutine run_and_accept(job, task, halted, accepted)
        class(farm_job), intent(inout) :: job !! the work
        integer, intent(in) :: task           !! task number
        logical, intent(inout) :: halted      !! shared: the collector stopped the run
        integer, intent(inout) :: accepted    !! shared: records accepted
        character(len=:), allocatable :: record
        logical :: stop_now, halt
        !$omp atomic read
        stop_now = halted
        if (stop_now) return
        call job%run(task, record)
        !$omp critical (holosym_farm_accept)
        halt = halted
        if (.not. halt) then
            call job%accept(task, record, halt)
            accepted = accepted + 1
        end if
        !$omp atomic write
        halted = halt
        !$omp end critical (holosym_farm_accept)
    end subroutine run_and_accept

    !> The number of threads a parallel region gets by default.
    integer function omp_default_threads() result(threads)
        !$ use omp_lib, only: omp_get_max_threads
        threads = 1
        !$ threads = omp_get_max_threads()
    end function omp_default_threads

end module holosym_task_farm
