!> Ensembles are many trajectories of one system, each from its own initial state, integrated
!! independently and in parallel by a task farm (threads of this process by default, MPI
!! ranks with the holosym-mpi package).
!!
!! `run_ensemble(sys, states, settings, results, status)` integrates trajectory k from
!! (states%q(:, k), states%p(:, k)) over nint(T/h) steps of the scheme (M, N, G) and returns
!! for each its status, steps done, final state, max |(H - H0)/H0|, max |phi|,
!! max |Phi H_p| and Newton iterations. A trajectory that fails records its status and
!! message in its result; the others go on.
!!
!! Every trajectory gets a freshly initialised integrator (a copy of `settings%integrator`
!! with its options) and nothing else: its result depends on its own initial state and
!! settings only, so results are bit for bit the same whatever the number of threads or
!! ranks and whichever worker computed them.
!!
!! An optional `ensemble_sink` receives each result as it completes (to write it at once,
!! so that a killed run loses nothing: see holosym_ensemble_files) and, on the worker that
!! computed it, the states sampled every `settings%every` steps.
module holosym_ensemble
    use, intrinsic :: iso_fortran_env, only: int64
    use, intrinsic :: iso_c_binding, only: c_int, c_long
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_manifold, only: manifold_residuals
    use holosym_projection, only: project_to_manifold
    use holosym_integrator, only: constrained_integrator, step_observer, step_info_t
    use holosym_events, only: event_set, event_t, integrate_events
    use holosym_task_farm, only: farm_job, task_farm, openmp_farm
    use holosym_records, only: record_reader_t, put
    implicit none
    private

    public :: ensemble_settings_t, ensemble_states_t, ensemble_result_t, ensemble_sink
    public :: run_ensemble, check_ensemble, ensemble_steps, integrate_member, sorted_order
    public :: perturbed_states, samples_failure

    !> Start of the message of a trajectory whose samples could not be stored (its code is
    !! then the sink's): a sink that writes files tells this I/O failure from the
    !! trajectory's own.
    character(len=*), parameter :: samples_failure = "storing the samples: "

    !> Relative tolerance for "T is a multiple of h" (decimal input is not exact in binary).
    real(wp), parameter :: multiple_tolerance = 64 * epsilon(1.0_wp)

    !> Settings shared by all trajectories of an ensemble.
    type :: ensemble_settings_t
        !> M >= 1: degree of the displacement polynomial.
        integer :: order_m = 2
        !> N >= 0: degree of the momentum polynomial.
        integer :: order_n = 1
        !> G >= 1: Gauss-Legendre points.
        integer :: gauss_points = 3
        !> Step size h > 0 of trajectories without their own (`states%step_size`).
        real(wp) :: step_size = 0.0625_wp
        !> Final time T >= 0 of trajectories without their own; nint(T/h) steps.
        real(wp) :: final_time = 10.0_wp
        !> Sample the state every `every` steps (and at t = 0 and the last step) for the
        !! sink's `store_samples`; 0 for none.
        integer :: every = 0
        !> Project each initial state onto the constraint manifold first; without it, an
        !! initial state off the manifold is an error of the whole call.
        logical :: project = .false.
        !> Options of every trajectory's integrator (speed options, Newton settings,
        !! manifold tolerance); copied, then initialised for (M, N, G).
        type(constrained_integrator) :: integrator
        !> A section (e.g. from `make_section`, or any `event_set`): each trajectory's
        !! crossings of it, located as `integrate_events` locates events, are returned in
        !! its result's `crossings` (a Poincare section). Not associated: none. Every
        !! worker reads it; it must outlive the run.
        class(event_set), pointer :: section => null()
        !> With a section: end each trajectory at its `crossing_limit`-th crossing (as at a
        !! terminal event); 0: run to T.
        integer :: crossing_limit = 0
    end type ensemble_settings_t

    !> The initial states: trajectory k starts from (q(:, k), p(:, k)).
    type :: ensemble_states_t
        !> Identifier of each trajectory (unique), K.
        integer, allocatable :: id(:)
        !> Coordinates, n x K.
        real(wp), allocatable :: q(:, :)
        !> Momenta, n x K.
        real(wp), allocatable :: p(:, :)
        !> Optional step size of each trajectory, K (unallocated: `settings%step_size`).
        real(wp), allocatable :: step_size(:)
        !> Optional final time of each trajectory, K (unallocated: `settings%final_time`).
        real(wp), allocatable :: final_time(:)
    end type ensemble_states_t

    !> What one trajectory did.
    type :: ensemble_result_t
        !> The trajectory's id.
        integer :: id = 0
        !> Whether it was computed in this call (false for those skipped).
        logical :: computed = .false.
        !> Status code (HOLOSYM_*): 0, or why it stopped early.
        integer :: code = HOLOSYM_SUCCESS
        !> Status message ("" on success).
        character(len=:), allocatable :: message
        !> Steps asked for: nint(T/h).
        integer :: steps = 0
        !> Steps completed.
        integer :: steps_done = 0
        !> State after the last completed step (the projected initial state if none).
        real(wp), allocatable :: q(:)
        real(wp), allocatable :: p(:)
        !> max |(H - H0)/H0| over the completed steps (max |H - H0| when H0 = 0).
        real(wp) :: max_energy_error = 0
        !> max |phi| over the initial state and every step's displacement nodes.
        real(wp) :: max_constraint_residual = 0
        !> max |Phi H_p| over the initial state and every step's end.
        real(wp) :: max_velocity_residual = 0
        !> Newton iterations over all steps.
        integer(int64) :: newton_iterations = 0
        !> CPU seconds of the thread that computed it (-1 when not measurable).
        real(wp) :: cpu_seconds = 0
        !> Wall-clock seconds.
        real(wp) :: wall_seconds = 0
        !> With `settings%section`: its crossings in time order, one column each: t,
        !! q(1:n), p(1:n) (2n + 1 rows); no columns when it was not crossed.
        real(wp), allocatable :: crossings(:, :)
        !> Sampled states when `settings%every` > 0, one column per sample:
        !! t, q(1:n), p(1:n), (H - H0)/H0, max|phi| of the step, |Phi H_p| (2n + 4 rows).
        !! Given to `store_samples` on the worker, not kept in `results`.
        real(wp), allocatable :: samples(:, :)
    end type ensemble_result_t

    !> Receives the results of `run_ensemble` as they complete. Extend it.
    type, abstract :: ensemble_sink
    contains
        !> A trajectory has completed: called on the collector, one result at a time, in
        !! the order of completion. Set `halt` to stop (no new trajectory is started).
        procedure(sink_completed_interface), deferred :: completed
        !> The sampled states of a trajectory (`settings%every` > 0), on the worker that
        !! computed it, before `completed` receives its result; one call at a time, while
        !! other trajectories are computed, so it must not change state that `completed`
        !! uses. A failure is recorded as the trajectory's status. Default: nothing is
        !! stored.
        procedure :: store_samples => ignore_samples
    end type ensemble_sink

    abstract interface
        subroutine sink_completed_interface(self, result, halt)
            import :: ensemble_sink, ensemble_result_t
            class(ensemble_sink), intent(inout) :: self  !! the sink
            type(ensemble_result_t), intent(in) :: result !! the completed trajectory
            logical, intent(inout) :: halt !! set .true. to stop the run
        end subroutine sink_completed_interface
    end interface

    !> The farm job of `run_ensemble`: task k is trajectory k.
    type, extends(farm_job) :: ensemble_job
        class(constrained_hamiltonian), pointer :: sys => null()
        type(ensemble_states_t), pointer :: states => null()
        class(ensemble_sink), pointer :: sink => null()
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t), allocatable :: results(:)
    contains
        procedure :: run => ensemble_job_run
        procedure :: accept => ensemble_job_accept
    end type ensemble_job

    !> Collects what `run_ensemble` reports per trajectory, step by step.
    type, extends(step_observer) :: member_monitor
        class(constrained_hamiltonian), pointer :: sys => null()
        real(wp) :: energy0 = 0
        real(wp) :: energy_scale = 1
        real(wp) :: max_energy_error = 0
        real(wp) :: max_constraint_residual = 0
        real(wp) :: max_velocity_residual = 0
        integer(int64) :: newton_iterations = 0
        integer :: every = 0
        integer :: steps = 0
        integer :: samples_taken = 0
        real(wp), allocatable :: samples(:, :)
    contains
        procedure :: observe => monitor_observe
        procedure :: take_sample_at
    end type member_monitor

    !> struct timespec of POSIX (time_t and long are both C long on LP64 Linux).
    type, bind(C) :: c_timespec
        integer(c_long) :: seconds
        integer(c_long) :: nanoseconds
    end type c_timespec

    !> CLOCK_THREAD_CPUTIME_ID of Linux: CPU time of the calling thread.
    integer(c_int), parameter :: clock_thread_cputime_id = 3

    interface
        integer(c_int) function c_clock_gettime(clock, time) bind(C, name="clock_gettime")
            import :: c_int, c_timespec
            integer(c_int), value :: clock
            type(c_timespec), intent(out) :: time
        end function c_clock_gettime
    end interface

contains

    !> Default `store_samples`: nothing is stored.
    subroutine ignore_samples(self, result, status)
        class(ensemble_sink), intent(in) :: self      !! the sink
        type(ensemble_result_t), intent(in) :: result !! the trajectory with its samples
        type(holosym_status_t), intent(out) :: status !! outcome
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine ignore_samples

    !> Number of steps of trajectory k: nint(T/h) with its own or the default h and T.
    !! Fails with HOLOSYM_INVALID_STEP_SIZE (h not positive and finite) or
    !! HOLOSYM_INVALID_STEP_COUNT (T negative, not finite, T/h more steps than an integer
    !! holds, decided on the exponents before dividing, or T > 0 with T/h rounding to 0
    !! steps).
    subroutine ensemble_steps(states, settings, k, h, steps, status)
        type(ensemble_states_t), intent(in) :: states     !! the initial states
        type(ensemble_settings_t), intent(in) :: settings !! the defaults
        integer, intent(in) :: k                          !! trajectory index
        real(wp), intent(out) :: h                        !! its step size
        integer, intent(out) :: steps                     !! its number of steps
        type(holosym_status_t), intent(out) :: status     !! outcome
        real(wp) :: span, ratio
        h = settings%step_size
        span = settings%final_time
        steps = 0
        if (allocated(states%step_size)) h = states%step_size(k)
        if (allocated(states%final_time)) span = states%final_time(k)
        if (.not. (is_finite(h) .and. h > 0)) then
            call set_status(status, HOLOSYM_INVALID_STEP_SIZE, "step size must be positive " &
                // "and finite; got h = " // real_str(h))
            return
        end if
        ratio = huge(1.0_wp)
        if (is_finite(span) .and. span >= 0) then
            ! T/h cannot overflow once its binary exponent fits an integer's bits.
            if (span == 0) then
                ratio = 0
            else if (exponent(span) - exponent(h) <= bit_size(steps)) then
                ratio = span / h
            end if
        end if
        if (.not. (is_finite(span) .and. span >= 0 .and. ratio <= real(huge(steps), wp))) then
            call set_status(status, HOLOSYM_INVALID_STEP_COUNT, "final time must be >= 0 " // &
                "and T/h at most " // int_str(huge(steps)) // " steps; got T = " // &
                real_str(span) // ", h = " // real_str(h))
            return
        end if
        steps = nint(ratio)
        if (steps == 0 .and. span > 0) then
            call set_status(status, HOLOSYM_INVALID_STEP_COUNT, "T/h rounds to 0 steps; got " &
                // "T = " // real_str(span) // ", h = " // real_str(h))
            return
        end if
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine ensemble_steps

    !> Check an ensemble before running it: sizes, unique ids, finite states, h, T and
    !! (M, N, G); without `settings%project`, that every initial state is on the constraint
    !! manifold. The message names the trajectory (index and id) and the value.
    !! Codes: HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_ARGUMENT
    !! (duplicate id, non-finite value, `every` < 0, `crossing_limit` < 0),
    !! HOLOSYM_INVALID_STEP_SIZE,
    !! HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_INVALID_ORDER, HOLOSYM_OFF_MANIFOLD and the
    !! integrator's other start-state checks.
    subroutine check_ensemble(sys, states, settings, status)
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        type(ensemble_states_t), intent(in) :: states     !! the initial states
        type(ensemble_settings_t), intent(in) :: settings !! the settings
        type(holosym_status_t), intent(out) :: status     !! outcome
        type(constrained_integrator) :: integrator
        type(holosym_status_t) :: local
        integer, allocatable :: order(:)
        real(wp), allocatable :: q(:), p(:)
        real(wp) :: h
        integer :: k, count, steps

        call set_status(status, HOLOSYM_SUCCESS, "")
        if (.not. (allocated(states%id) .and. allocated(states%q) .and. &
                   allocated(states%p))) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "states%id, states%q and " // &
                "states%p must be allocated")
            return
        end if
        count = size(states%id)
        if (sys%n < 1 .or. sys%m < 0 .or. sys%m >= sys%n) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "need n >= 1 and 0 <= m < n; " &
                // "got n = " // int_str(sys%n) // ", m = " // int_str(sys%m))
        else if (any(shape(states%q) /= [sys%n, count]) .or. &
                 any(shape(states%p) /= [sys%n, count])) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "states%q and states%p must be " // &
                "n x K = " // int_str(sys%n) // " x " // int_str(count) // "; got " // &
                int_str(size(states%q, 1)) // " x " // int_str(size(states%q, 2)) // " and " // &
                int_str(size(states%p, 1)) // " x " // int_str(size(states%p, 2)))
        else if (sized_wrong(states%step_size) .or. sized_wrong(states%final_time)) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "states%step_size and " // &
                "states%final_time, when allocated, must have size K = " // int_str(count))
        else if (settings%every < 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "every must be >= 0; got " // &
                int_str(settings%every))
        else if (settings%crossing_limit < 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "crossing_limit must be >= 0; " &
                // "got " // int_str(settings%crossing_limit))
        end if
        if (.not. status%ok()) return
        ! Duplicate ids: sort a permutation, compare neighbours.
        order = sorted_order(states%id)
        do k = 2, count
            if (states%id(order(k)) == states%id(order(k - 1))) then
                call set_status(status, HOLOSYM_INVALID_ARGUMENT, "duplicate id " // &
                    int_str(states%id(order(k))) // " (trajectories " // &
                    int_str(min(order(k), order(k - 1))) // " and " // &
                    int_str(max(order(k), order(k - 1))) // ")")
                return
            end if
        end do
        integrator = settings%integrator
        call integrator%init(sys, settings%order_m, settings%order_n, settings%gauss_points, &
                             local)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        do k = 1, count
            if (.not. (all(is_finite(states%q(:, k))) .and. all(is_finite(states%p(:, k))))) then
                call set_status(status, HOLOSYM_INVALID_ARGUMENT, trajectory_name(k) // &
                    ": q or p contains NaN or Inf")
                return
            end if
            call ensemble_steps(states, settings, k, h, steps, local)
            ! The integrator's own start-state checks (manifold, rank, finiteness of the
            ! system's values), by a run of no steps.
            if (local%ok() .and. .not. settings%project) then
                q = states%q(:, k)
                p = states%p(:, k)
                call integrator%integrate(sys, q, p, h, 0, status=local)
            end if
            if (.not. local%ok()) then
                call set_status(status, local%code, trajectory_name(k) // ": " // &
                    local%message)
                return
            end if
        end do
    contains
        logical function sized_wrong(values)
            real(wp), allocatable, intent(in) :: values(:)
            sized_wrong = .false.
            if (allocated(values)) sized_wrong = size(values) /= count
        end function sized_wrong

        function trajectory_name(k) result(name)
            integer, intent(in) :: k
            character(len=:), allocatable :: name
            name = "trajectory " // int_str(k) // " (id " // int_str(states%id(k)) // ")"
        end function trajectory_name
    end subroutine check_ensemble

    !> Integrate trajectories and return one result per trajectory.
    !!
    !! The ensemble is first checked (`check_ensemble`); on a failure nothing runs and
    !! `results` is unchanged. Otherwise every trajectory not marked in `skip` is
    !! integrated by the farm (default: `openmp_farm()`, the threads of OMP_NUM_THREADS)
    !! and handed to `sink%completed` as it completes; `status` is then success even when
    !! some trajectories failed: their own `code` and `message` say why (count them with
    !! `count(results%code /= 0)`). `results(k)` is the result of trajectory k, `computed`
    !! false for a skipped one. With an MPI farm, every rank calls `run_ensemble` with the
    !! same arguments and `results` is complete on the collector (rank 0) only.
    !! Codes: those of `check_ensemble`, HOLOSYM_SIZE_MISMATCH (`skip` not of size K) and
    !! HOLOSYM_USER_ABORT (the sink halted the run; `results` is then unchanged).
    subroutine run_ensemble(sys, states, settings, results, status, sink, farm, skip)
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        type(ensemble_states_t), intent(in), target :: states     !! the initial states
        type(ensemble_settings_t), intent(in) :: settings         !! shared settings
        !> One result per trajectory, in the order of `states`.
        type(ensemble_result_t), allocatable, intent(inout) :: results(:)
        type(holosym_status_t), intent(out), optional :: status   !! outcome
        class(ensemble_sink), intent(inout), target, optional :: sink !! receives results
        class(task_farm), intent(inout), optional :: farm         !! who computes
        logical, intent(in), optional :: skip(:) !! trajectories not to compute (K)
        type(ensemble_job) :: job
        type(openmp_farm) :: threads
        type(holosym_status_t) :: local
        integer, allocatable :: tasks(:)
        integer :: k

        call check_ensemble(sys, states, settings, local)
        if (local%ok() .and. present(skip)) then
            if (size(skip) /= size(states%id)) call set_status(local, HOLOSYM_SIZE_MISMATCH, &
                "skip must have size K = " // int_str(size(states%id)) // "; got " // &
                int_str(size(skip)))
        end if
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        job%sys => sys
        job%states => states
        if (present(sink)) job%sink => sink
        job%settings = settings
        allocate (job%results(size(states%id)))
        do k = 1, size(states%id)
            job%results(k)%id = states%id(k)
            job%results(k)%message = ""
            job%results(k)%q = states%q(:, k)
            job%results(k)%p = states%p(:, k)
        end do
        tasks = [(k, k = 1, size(states%id))]
        if (present(skip)) tasks = pack(tasks, .not. skip)
        if (present(farm)) then
            call farm%execute(job, tasks, local)
        else
            call threads%execute(job, tasks, local)
        end if
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        call move_alloc(job%results, results)
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine run_ensemble

    !> Integrate trajectory k of a checked ensemble (see `check_ensemble`) with a fresh
    !! integrator: the work of one task of `run_ensemble`, for drivers of one's own.
    !! Failures are recorded in `result`, never raised.
    subroutine integrate_member(sys, states, settings, k, result)
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        type(ensemble_states_t), intent(in) :: states     !! the initial states
        type(ensemble_settings_t), intent(in) :: settings !! shared settings
        integer, intent(in) :: k                          !! trajectory index
        type(ensemble_result_t), intent(out) :: result    !! what it did
        type(constrained_integrator) :: integrator
        type(member_monitor) :: monitor
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:)
        real(wp) :: h, cpu_start, position, velocity
        integer(int64) :: clock_start, clock_end, clock_rate
        integer :: steps_done

        call system_clock(clock_start, clock_rate)
        cpu_start = thread_cpu_seconds()
        result%id = states%id(k)
        result%computed = .true.
        q = states%q(:, k)
        p = states%p(:, k)
        call ensemble_steps(states, settings, k, h, result%steps, status)
        if (status%ok() .and. settings%project) then
            call project_to_manifold(sys, q, p, status)
            if (.not. status%ok()) status%message = "projection onto the constraint " // &
                "manifold: " // status%message
        end if
        if (status%ok()) then
            integrator = settings%integrator
            call integrator%init(sys, settings%order_m, settings%order_n, &
                                 settings%gauss_points, status)
        end if
        if (status%ok()) then
            monitor%sys => sys
            monitor%energy0 = sys%hamiltonian(q, p)
            monitor%energy_scale = monitor%energy0
            if (.not. (abs(monitor%energy_scale) > 0)) monitor%energy_scale = 1
            call manifold_residuals(sys, q, p, position, velocity)
            monitor%max_constraint_residual = position
            monitor%max_velocity_residual = velocity
            monitor%steps = result%steps
            monitor%every = settings%every
            if (settings%every > 0) then
                allocate (monitor%samples(2 * sys%n + 4, result%steps / settings%every + 2))
                call monitor%take_sample_at(0.0_wp, q, p, 0.0_wp, position, velocity)
            end if
            if (associated(settings%section)) then
                call integrate_crossings(integrator, sys, q, p, h, result%steps, settings, &
                                         monitor, steps_done, result%crossings, status)
            else
                call integrator%integrate(sys, q, p, h, result%steps, monitor, steps_done, &
                                          status)
            end if
            result%steps_done = steps_done
            result%max_energy_error = monitor%max_energy_error
            result%max_constraint_residual = monitor%max_constraint_residual
            result%max_velocity_residual = monitor%max_velocity_residual
            result%newton_iterations = monitor%newton_iterations
            if (settings%every > 0) result%samples = monitor%samples(:, :monitor%samples_taken)
        end if
        result%code = status%code
        result%message = ""
        if (.not. status%ok()) result%message = status%message
        result%q = q
        result%p = p
        result%cpu_seconds = thread_cpu_seconds()
        if (result%cpu_seconds >= 0 .and. cpu_start >= 0) then
            result%cpu_seconds = result%cpu_seconds - cpu_start
        else
            result%cpu_seconds = -1
        end if
        call system_clock(clock_end)
        result%wall_seconds = real(clock_end - clock_start, wp) / clock_rate
    end subroutine integrate_member

    !> The run of a trajectory with a section: `integrate_events` with the monitor as its
    !! observer; the crossings as columns t, q, p.
    subroutine integrate_crossings(integrator, sys, q, p, h, steps, settings, monitor, &
                                   steps_done, crossings, status)
        type(constrained_integrator), intent(inout) :: integrator
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(inout) :: q(:), p(:)
        real(wp), intent(in) :: h
        integer, intent(in) :: steps
        type(ensemble_settings_t), intent(in) :: settings
        type(member_monitor), intent(inout) :: monitor
        integer, intent(out) :: steps_done
        real(wp), allocatable, intent(out) :: crossings(:, :)
        type(holosym_status_t), intent(out) :: status
        type(event_t), allocatable :: found(:)
        logical :: stopped
        integer :: j, n, limit
        limit = huge(1)
        if (settings%crossing_limit > 0) limit = settings%crossing_limit
        call integrate_events(integrator, sys, q, p, h, steps, settings%section, found, &
                              stopped, status, steps_done, observer=monitor, limit=limit)
        n = size(q)
        allocate (crossings(2 * n + 1, size(found)))
        do j = 1, size(found)
            crossings(:, j) = [found(j)%t, found(j)%q, found(j)%p]
        end do
    end subroutine integrate_crossings

    !> Record the step's diagnostics, and a sample at every `every`-th and the last step.
    subroutine monitor_observe(self, step, t, q, p, info, halt)
        class(member_monitor), intent(inout) :: self !! the monitor
        integer, intent(in) :: step          !! step number k >= 1
        real(wp), intent(in) :: t            !! time k h
        real(wp), intent(in) :: q(:)         !! coordinates after the step
        real(wp), intent(in) :: p(:)         !! momenta after the step
        type(step_info_t), intent(in) :: info !! diagnostics of the step
        logical, intent(inout) :: halt       !! not used
        real(wp) :: energy_error
        energy_error = self%sys%hamiltonian(q, p)
        if (is_finite(energy_error)) then
            energy_error = (energy_error - self%energy0) / self%energy_scale
            self%max_energy_error = max(self%max_energy_error, abs(energy_error))
        else
            ! H returned NaN or Inf (possible only with check_roots off): unbounded, found
            ! by classification (no comparison with a NaN).
            energy_error = ieee_value(energy_error, ieee_positive_inf)
            self%max_energy_error = energy_error
        end if
        self%max_constraint_residual = max(self%max_constraint_residual, &
                                           info%constraint_residual)
        self%max_velocity_residual = max(self%max_velocity_residual, info%velocity_residual)
        self%newton_iterations = self%newton_iterations + info%newton_iterations
        if (self%every > 0) then
            if (mod(step, self%every) == 0 .or. step == self%steps) &
                call self%take_sample_at(t, q, p, energy_error, info%constraint_residual, &
                                         info%velocity_residual)
        end if
    end subroutine monitor_observe

    !> Append one sample column.
    subroutine take_sample_at(self, t, q, p, energy_error, position, velocity)
        class(member_monitor), intent(inout) :: self
        real(wp), intent(in) :: t, q(:), p(:), energy_error, position, velocity
        integer :: n
        n = size(q)
        self%samples_taken = self%samples_taken + 1
        associate (column => self%samples(:, self%samples_taken))
            column(1) = t
            column(2:n + 1) = q
            column(n + 2:2 * n + 1) = p
            column(2 * n + 2) = energy_error
            column(2 * n + 3) = position
            column(2 * n + 4) = velocity
        end associate
    end subroutine take_sample_at

    !> Task k: integrate trajectory k, let the sink store its samples, pack the result.
    subroutine ensemble_job_run(self, task, record)
        class(ensemble_job), intent(in) :: self !! the job
        integer, intent(in) :: task             !! trajectory index
        character(len=:), allocatable, intent(out) :: record !! the packed result
        type(ensemble_result_t) :: result
        type(holosym_status_t) :: status
        call integrate_member(self%sys, self%states, self%settings, task, result)
        if (allocated(result%samples) .and. associated(self%sink)) then
            ! One sink call at a time: gfortran (12) keeps the length of a function result
            ! of deferred length in a static variable at each call site, so two threads in
            ! the same text-building code corrupt each other's strings and the heap.
            !$omp critical (holosym_store_samples)
            call self%sink%store_samples(result, status)
            !$omp end critical (holosym_store_samples)
            if (.not. status%ok() .and. result%code == HOLOSYM_SUCCESS) then
                result%code = status%code
                result%message = samples_failure // status%message
            end if
        end if
        record = ""
        call put(record, result%id)
        call put(record, result%code)
        call put(record, result%message)
        call put(record, result%steps)
        call put(record, result%steps_done)
        call put(record, result%q)
        call put(record, result%p)
        call put(record, result%max_energy_error)
        call put(record, result%max_constraint_residual)
        call put(record, result%max_velocity_residual)
        call put(record, result%newton_iterations)
        call put(record, result%cpu_seconds)
        call put(record, result%wall_seconds)
        if (.not. allocated(result%crossings)) allocate (result%crossings(0, 0))
        call put(record, size(result%crossings, 2))
        call put(record, reshape(result%crossings, [size(result%crossings)]))
    end subroutine ensemble_job_run

    !> Unpack the result of trajectory `task` and hand it to the sink.
    subroutine ensemble_job_accept(self, task, record, halt)
        class(ensemble_job), intent(inout) :: self !! the job
        integer, intent(in) :: task                !! trajectory index
        character(len=*), intent(in) :: record     !! from `ensemble_job_run`
        logical, intent(inout) :: halt             !! set by the sink
        type(record_reader_t) :: reader
        integer :: crossings
        associate (r => self%results(task))
            r%id = reader%integer(record)
            r%code = reader%integer(record)
            r%message = reader%text(record)
            r%steps = reader%integer(record)
            r%steps_done = reader%integer(record)
            r%q = reader%reals(record)
            r%p = reader%reals(record)
            r%max_energy_error = reader%real(record)
            r%max_constraint_residual = reader%real(record)
            r%max_velocity_residual = reader%real(record)
            r%newton_iterations = reader%integer64(record)
            r%cpu_seconds = reader%real(record)
            r%wall_seconds = reader%real(record)
            crossings = reader%integer(record)
            r%crossings = reshape(reader%reals(record), [2 * size(r%q) + 1, max(0, crossings)], &
                                  pad=[0.0_wp])
            r%computed = .not. reader%overrun
            if (reader%overrun) then
                r%code = HOLOSYM_INVALID_ARGUMENT
                r%message = "the result record of this trajectory was truncated"
            end if
            if (associated(self%sink)) call self%sink%completed(r, halt)
        end associate
    end subroutine ensemble_job_accept

    !> CPU seconds of the calling thread (POSIX clock_gettime); -1 when unavailable.
    real(wp) function thread_cpu_seconds() result(seconds)
        type(c_timespec) :: time
        seconds = -1
        if (c_clock_gettime(clock_thread_cputime_id, time) == 0) &
            seconds = real(time%seconds, wp) + real(time%nanoseconds, wp) * 1.0e-9_wp
    end function thread_cpu_seconds

    !> `count` states around (q0, p0), ids 1..count: every coordinate and momentum of state
    !! k moved by scale u with u uniform in [-1, 1), drawn from L'Ecuyer's combined
    !! generator seeded by (seed, k). The same states on every machine and in every
    !! process, whatever `count` (state k does not depend on the others). They are off
    !! the constraint manifold: run them with `settings%project`.
    !! Fails with HOLOSYM_INVALID_ARGUMENT (count < 1, scale negative or not finite,
    !! q0/p0 of different sizes); `states` is then unchanged.
    subroutine perturbed_states(q0, p0, count, scale, seed, states, status)
        real(wp), intent(in) :: q0(:)  !! base coordinates (n)
        real(wp), intent(in) :: p0(:)  !! base momenta (n)
        integer, intent(in) :: count   !! number of states K >= 1
        real(wp), intent(in) :: scale  !! perturbation size >= 0
        integer, intent(in) :: seed    !! any integer
        type(ensemble_states_t), intent(inout) :: states !! the states
        type(holosym_status_t), intent(out), optional :: status !! outcome
        integer(int64), parameter :: m1 = 2147483563_int64, m2 = 2147483399_int64
        integer(int64) :: s1, s2, z
        integer :: k, i, n
        n = size(q0)
        if (count < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "count must be >= 1; got " // &
                int_str(count))
            return
        else if (.not. (is_finite(scale) .and. scale >= 0)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "scale must be >= 0 and " // &
                "finite; got " // real_str(scale))
            return
        else if (size(p0) /= n) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "q0 and p0 must have the " // &
                "same size; got " // int_str(n) // " and " // int_str(size(p0)))
            return
        end if
        if (allocated(states%step_size)) deallocate (states%step_size)
        if (allocated(states%final_time)) deallocate (states%final_time)
        states%id = [(k, k = 1, count)]
        states%q = spread(q0, 2, count)
        states%p = spread(p0, 2, count)
        do k = 1, count
            s1 = 1 + modulo(40014_int64 * seed + k, m1 - 1)
            s2 = 1 + modulo(int(seed, int64) + 40692_int64 * k, m2 - 1)
            do i = 1, 8
                z = uniform()
            end do
            do i = 1, n
                states%q(i, k) = q0(i) + scale * (2 * real(uniform(), wp) / m1 - 1)
            end do
            do i = 1, n
                states%p(i, k) = p0(i) + scale * (2 * real(uniform(), wp) / m1 - 1)
            end do
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    contains
        !> The next value of the combined generator, in 0 .. m1 - 2.
        integer(int64) function uniform()
            s1 = modulo(40014_int64 * s1, m1)
            s2 = modulo(40692_int64 * s2, m2)
            uniform = modulo(s1 - s2, m1 - 1)
        end function uniform
    end subroutine perturbed_states

    !> The permutation that sorts `keys` ascending (stable merge sort).
    pure function sorted_order(keys) result(order)
        integer, intent(in) :: keys(:) !! the keys
        integer, allocatable :: order(:)
        integer, allocatable :: work(:)
        integer :: width, first, middle, last, i, j, k
        order = [(i, i = 1, size(keys))]
        allocate (work(size(keys)))
        width = 1
        do while (width < size(keys))
            do first = 1, size(keys), 2 * width
                middle = min(first + width - 1, size(keys))
                last = min(first + 2 * width - 1, size(keys))
                i = first
                j = middle + 1
                do k = first, last
                    if (j > last) then
                        work(k) = order(i)
                        i = i + 1
                    else if (i > middle) then
                        work(k) = order(j)
                        j = j + 1
                    else if (keys(order(j)) < keys(order(i))) then
                        work(k) = order(j)
                        j = j + 1
                    else
                        work(k) = order(i)
                        i = i + 1
                    end if
                end do
            end do
            order = work
            width = 2 * width
        end do
    end function sorted_order

end module holosym_ensemble
