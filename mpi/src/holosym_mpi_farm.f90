!> The task farm on MPI ranks (see holosym_task_farm): dynamic load balancing by a manager
!! on rank 0, which also collects every record.
!!
!! Rank 0 runs two threads: the manager (the thread that called MPI_Init_thread: MPI needs
!! only MPI_THREAD_FUNNELED) and a local worker, so that every rank computes. The manager
!! hands out one task at a time to whichever worker asks (ranks 1.. by message, the local
!! worker through shared memory), receives each result, calls the job's `accept` on it
!! and answers with the next task, or with "stop" when none is left. A worker therefore
!! has at most one task in hand, and a slow task never holds up the others: this is the
!! load balancing. Per task there is one message each way (a task number out, a record of
!! a few hundred bytes back). Between messages the manager sleeps a millisecond, so it costs
!! next to no CPU and rank 0's core stays with its local worker.
!!
!! Only rank 0 accepts (writes) results; ranks 1.. never touch the collector's files. If
!! any rank dies, mpirun ends the job: everything accepted so far has been written.
module holosym_mpi_farm
    use, intrinsic :: iso_c_binding, only: c_int
    use mpi_f08, only: MPI_Comm, MPI_Status, MPI_COMM_WORLD, MPI_ANY_SOURCE, MPI_ANY_TAG, &
        MPI_CHARACTER, MPI_INTEGER, MPI_LOGICAL, MPI_LAND, MPI_Comm_rank, MPI_Comm_size, &
        MPI_Iprobe, MPI_Probe, MPI_Get_count, MPI_Recv, MPI_Send, MPI_Allreduce, MPI_Bcast
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_USER_ABORT
    use holosym_task_farm, only: farm_job, task_farm
    use holosym_records, only: record_reader_t, put
    implicit none
    private

    public :: mpi_farm

    !> Message tags: a worker's first request, a result, a task, the end.
    integer, parameter :: tag_ready = 1, tag_result = 2, tag_task = 3, tag_stop = 4
    !> States of the local worker's slot on rank 0.
    integer, parameter :: slot_idle = 0, slot_assigned = 1, slot_done = 2, slot_stop = -1
    !> Microseconds the manager and the idle local worker sleep when nothing happened.
    integer(c_int), parameter :: idle_sleep = 1000

    !> Tasks on the ranks of an MPI communicator (every rank calls `execute`).
    type, extends(task_farm) :: mpi_farm
        !> The communicator of the farm.
        type(MPI_Comm) :: comm = MPI_COMM_WORLD
    contains
        procedure :: execute => mpi_execute
        procedure :: is_collector => mpi_is_collector
        procedure :: agree => mpi_agree
        procedure :: processes => mpi_processes
    end type mpi_farm

    !> The local worker's slot on rank 0, shared by the manager and the local worker.
    type :: local_slot
        integer :: state = slot_idle
        integer :: task = 0
        character(len=:), allocatable :: record
    end type local_slot

    interface
        integer(c_int) function c_usleep(microseconds) bind(C, name="usleep")
            import :: c_int
            integer(c_int), value :: microseconds
        end function c_usleep
    end interface

contains

    !> Rank 0 collects.
    logical function mpi_is_collector(self) result(collector)
        class(mpi_farm), intent(in) :: self !! the farm
        integer :: rank
        call MPI_Comm_rank(self%comm, rank)
        collector = rank == 0
    end function mpi_is_collector

    !> `ok` on every rank (MPI_Allreduce with MPI_LAND).
    logical function mpi_agree(self, ok) result(all_ok)
        class(mpi_farm), intent(inout) :: self !! the farm
        logical, intent(in) :: ok !! this rank's verdict
        call MPI_Allreduce(ok, all_ok, 1, MPI_LOGICAL, MPI_LAND, self%comm)
    end function mpi_agree

    !> Number of ranks.
    integer function mpi_processes(self) result(count)
        class(mpi_farm), intent(in) :: self !! the farm
        call MPI_Comm_size(self%comm, count)
    end function mpi_processes

    !> Run the tasks: rank 0 manages (and computes on a second thread), the other ranks
    !! compute. Every rank returns the same status: HOLOSYM_USER_ABORT when `accept` halted
    !! the run.
    subroutine mpi_execute(self, job, tasks, status)
        class(mpi_farm), intent(inout) :: self  !! the farm
        class(farm_job), intent(inout) :: job   !! the work
        integer, intent(in) :: tasks(:)         !! task numbers, in order (rank 0's are used)
        type(holosym_status_t), intent(out) :: status !! outcome
        type(local_slot) :: slot
        integer :: rank, accepted, thread, team
        logical :: halted

        call MPI_Comm_rank(self%comm, rank)
        halted = .false.
        accepted = 0
        if (rank == 0) then
            thread = 0
            team = 1
            !$omp parallel num_threads(2) default(shared) private(thread)
            !$ thread = omp_thread()
            !$ team = omp_team()
            if (thread == 0) then
                call manage(self%comm, job, tasks, slot, halted, accepted, team >= 2)
            else
                call work_locally(job, slot)
            end if
            !$omp end parallel
        else
            call work_remotely(self%comm, job)
        end if
        call MPI_Bcast(halted, 1, MPI_LOGICAL, 0, self%comm)
        call MPI_Bcast(accepted, 1, MPI_INTEGER, 0, self%comm)
        if (halted) then
            call set_status(status, HOLOSYM_USER_ABORT, "the collector stopped the run after " &
                // int_str(accepted) // " tasks")
        else
            call set_status(status, HOLOSYM_SUCCESS, "")
        end if
    end subroutine mpi_execute

    !> The number of the calling OpenMP thread.
    integer function omp_thread()
        !$ use omp_lib, only: omp_get_thread_num
        omp_thread = 0
        !$ omp_thread = omp_get_thread_num()
    end function omp_thread

    !> The number of threads of the current team.
    integer function omp_team()
        !$ use omp_lib, only: omp_get_num_threads
        omp_team = 1
        !$ omp_team = omp_get_num_threads()
    end function omp_team

    !> The manager on rank 0: answer every worker's request with the next task (or stop),
    !! accept every result. Without a second thread it also runs the local tasks itself.
    subroutine manage(comm, job, tasks, slot, halted, accepted, threaded)
        type(MPI_Comm), intent(in) :: comm
        class(farm_job), intent(inout) :: job
        integer, intent(in) :: tasks(:)
        type(local_slot), intent(inout) :: slot
        logical, intent(inout) :: halted
        integer, intent(inout) :: accepted
        logical, intent(in) :: threaded
        type(MPI_Status) :: message
        type(record_reader_t) :: reader
        character(len=:), allocatable :: buffer, record
        integer :: next, remote_active, length, task, size, state, ignored
        logical :: arrived, progressed, local_active

        call MPI_Comm_size(comm, size)
        next = 1
        remote_active = size - 1
        local_active = .true.
        do while (remote_active > 0 .or. local_active)
            progressed = .false.
            ! Messages of the remote workers: a first request or a result.
            do
                call MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, comm, arrived, message)
                if (.not. arrived) exit
                progressed = .true.
                call MPI_Get_count(message, MPI_CHARACTER, length)
                if (allocated(buffer)) deallocate (buffer)
                allocate (character(len=max(length, 1)) :: buffer)
                call MPI_Recv(buffer, length, MPI_CHARACTER, message%MPI_SOURCE, &
                              message%MPI_TAG, comm, message)
                if (message%MPI_TAG == tag_result) then
                    reader = record_reader_t()
                    task = reader%integer(buffer(:length))
                    call take_record(task, buffer(reader%position:length))
                end if
                if (.not. halted .and. next <= size_of_tasks()) then
                    call MPI_Send(tasks(next), 1, MPI_INTEGER, message%MPI_SOURCE, tag_task, &
                                  comm)
                    next = next + 1
                else
                    call MPI_Send(0, 1, MPI_INTEGER, message%MPI_SOURCE, tag_stop, comm)
                    remote_active = remote_active - 1
                end if
            end do
            ! The local worker.
            if (local_active) then
                if (.not. threaded) then
                    ! No second thread: the manager computes the local share itself.
                    if (.not. halted .and. next <= size_of_tasks()) then
                        task = tasks(next)
                        next = next + 1
                        call job%run(task, record)
                        call take_record(task, record)
                        progressed = .true.
                    else
                        local_active = .false.
                    end if
                else
                    !$omp critical (holosym_mpi_slot)
                    state = slot%state
                    if (state == slot_done) then
                        task = slot%task
                        call move_alloc(slot%record, record)
                        slot%state = slot_idle
                    end if
                    !$omp end critical (holosym_mpi_slot)
                    if (state == slot_done) then
                        call take_record(task, record)
                        progressed = .true.
                        state = slot_idle
                    end if
                    if (state == slot_idle) then
                        progressed = .true.
                        !$omp critical (holosym_mpi_slot)
                        if (.not. halted .and. next <= size_of_tasks()) then
                            slot%task = tasks(next)
                            slot%state = slot_assigned
                            next = next + 1
                        else
                            slot%state = slot_stop
                            local_active = .false.
                        end if
                        !$omp end critical (holosym_mpi_slot)
                    end if
                end if
            end if
            if (.not. progressed) ignored = c_usleep(idle_sleep)
        end do
    contains
        integer function size_of_tasks()
            size_of_tasks = ubound(tasks, 1)
        end function size_of_tasks

        subroutine take_record(task, record)
            integer, intent(in) :: task
            character(len=*), intent(in) :: record
            if (halted) return
            call job%accept(task, record, halted)
            accepted = accepted + 1
        end subroutine take_record
    end subroutine manage

    !> The local worker on rank 0's second thread: wait for a task in the slot, compute it,
    !! leave its record there; until told to stop.
    subroutine work_locally(job, slot)
        class(farm_job), intent(inout) :: job
        type(local_slot), intent(inout) :: slot
        character(len=:), allocatable :: record
        integer :: state, task, ignored
        do
            !$omp critical (holosym_mpi_slot)
            state = slot%state
            task = slot%task
            !$omp end critical (holosym_mpi_slot)
            if (state == slot_stop) exit
            if (state /= slot_assigned) then
                ignored = c_usleep(idle_sleep)
                cycle
            end if
            call job%run(task, record)
            !$omp critical (holosym_mpi_slot)
            call move_alloc(record, slot%record)
            slot%state = slot_done
            !$omp end critical (holosym_mpi_slot)
        end do
    end subroutine work_locally

    !> A worker on ranks 1..: ask for a task, compute it, send its record (which asks for
    !! the next), until told to stop.
    subroutine work_remotely(comm, job)
        type(MPI_Comm), intent(in) :: comm
        class(farm_job), intent(inout) :: job
        type(MPI_Status) :: message
        character(len=:), allocatable :: record, packet
        integer :: task
        call MPI_Send("", 0, MPI_CHARACTER, 0, tag_ready, comm)
        do
            call MPI_Recv(task, 1, MPI_INTEGER, 0, MPI_ANY_TAG, comm, message)
            if (message%MPI_TAG == tag_stop) exit
            call job%run(task, record)
            packet = ""
            call put(packet, task)
            packet = packet // record
            call MPI_Send(packet, len(packet), MPI_CHARACTER, 0, tag_result, comm)
        end do
    end subroutine work_remotely

end module holosym_mpi_farm
