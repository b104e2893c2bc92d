!> Work-precision benchmark: holosym (M = 1..8, N = M - 1, G = M and M + 1, fast options)
!! against RATTLE composed to orders 2-10 inside holosym (GNI_COMP's compositions), on
!! the spherical pendulum
!! (T = 10), the spring-linkage (T = 10) and the planar pendulum (T = 100), over a
!! geometric sweep of h; plus a per-step comparison of the speed options with the plain
!! path. CPU seconds are process CPU time (`cpu_time`), one core, median of 3 for runs
!! under `short_run` seconds.
module holosym_benchmark
    use, intrinsic :: iso_fortran_env, only: real64, int64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, &
        status_code_name, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_STEP_TOO_LARGE
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator, step_info_t
    use holosym_manifold, only: manifold_residuals
    use holosym_rattle, only: rattle_integrator
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy
    use holosym_progress, only: progress_clock_t
    implicit none
    private

    public :: bench_row_t, bench_settings_t, reference_state, holosym_run, rattle_run, &
              sweep_holosym, sweep_rattle, configure_variant, variant_name, bench_span, &
              accuracy_run, &
              bench_targets, variant_count, rattle_families, rattle_orders, target_in_precision

    !> Runs shorter than this (seconds) are repeated three times and the median is kept.
    real(real64), parameter :: short_run = 0.2_real64
    !> Option sets of the per-step comparison: 0 plain ... variant_count all fast.
    integer, parameter :: variant_count = 9
    !> Error targets: 1e-6 .. 1e-14 in real64, 1e-10 .. 1e-30 in real128.
    real(wp), parameter :: bench_targets(7) = [1.0e-6_wp, 1.0e-10_wp, 1.0e-14_wp, &
        1.0e-18_wp, 1.0e-22_wp, 1.0e-26_wp, 1.0e-30_wp]
    !> RATTLE compositions of the sweep: plain RATTLE, the fractal compositions to order 6
    !! and GNI_COMP's optimised compositions (order 2 of 'triple-jump' is RATTLE itself).
    character(len=*), parameter :: rattle_families(10) = [character(len=18) :: &
        "triple-jump", "triple-jump", "suzuki", "triple-jump", "yoshida", "kahan-li", &
        "suzuki-umeno", "kahan-li", "hlw", "sofroniou-spaletta"]
    integer, parameter :: rattle_orders(10) = [2, 4, 4, 6, 6, 6, 8, 8, 10, 10]

    !> One measured run.
    type :: bench_row_t
        character(len=16) :: system = ""    !! pendulum, linkage or planar
        character(len=32) :: method = ""    !! holosym, holosym-plain, rattle-<family>, heyoka
        character(len=8) :: precision = ""  !! real128 or real64
        integer :: order_m = 0, order_n = 0, gauss_points = 0 !! (M, N, G); 0 for RATTLE
        integer :: order = 0                !! convergence order
        real(wp) :: h = 0                   !! step size
        integer :: steps = 0                !! number of steps
        real(wp) :: error = 0               !! max(|q - q_ref|, |p - p_ref|) at T
        real(wp) :: energy_error = 0        !! max_t |(H_t - H_0)/H_0|
        real(wp) :: constraint_residual = 0 !! max over steps of max|phi|, max|Phi H_p|
        real(real64) :: seconds = 0         !! CPU seconds of the run
        integer(int64) :: newton_iterations = 0, residuals = 0, gradients = 0, hessians = 0
        integer(int64) :: factorizations = 0
        integer :: code = 0                 !! status code of the run
        !> Per-step comparison: max |state - plain path's state| at T (else 0).
        real(wp) :: difference = 0
        !> heyoka: the tolerance of the run (else 0).
        real(wp) :: tolerance = 0
        !> heyoka: CPU seconds of building (compiling) the integrator; holosym-accuracy:
        !! of the pilot of `init_for_accuracy`. Not in `seconds`.
        real(real64) :: compile_seconds = 0
    end type bench_row_t

    !> Settings of a sweep.
    type :: bench_settings_t
        !> Stop refining once a run takes longer than this (CPU seconds).
        real(real64) :: budget = 1.5_real64
        !> Stop refining once the error is below this.
        real(wp) :: error_floor = 1.0e-31_wp
        !> Step counts grow by this factor per level.
        real(wp) :: refinement = sqrt(2.0_wp)
        !> Largest number of levels.
        integer :: max_levels = 40
        !> Progress lines to this unit (< 0: none).
        integer :: progress_unit = -1
        !> The command's start, and which sweep of how many this is, for progress lines.
        type(progress_clock_t) :: clock
        integer :: sweep = 1, sweeps = 1
        !> holosym's Newton tolerance (`newton%tolerance`); 0: the default (8 epsilon).
        real(wp) :: newton_tolerance = 0
    end type bench_settings_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> Whether a target of `bench_targets` belongs to a precision's table.
    pure logical function target_in_precision(target, precision)
        real(wp), intent(in) :: target          !! error target
        character(len=*), intent(in) :: precision !! real128 or real64
        if (precision == "real64") then
            target_in_precision = target >= 1.0e-14_wp * (1 - sqrt(epsilon(1.0_wp)))
        else
            target_in_precision = target <= 1.0e-10_wp * (1 + sqrt(epsilon(1.0_wp)))
        end if
    end function target_in_precision

    !> T of the benchmark for a system.
    pure function bench_span(system) result(span)
        character(len=*), intent(in) :: system !! system name
        real(wp) :: span
        span = 10
        if (system == "planar") span = 100
    end function bench_span

    !> Name of option set `variant` of the per-step comparison.
    pure function variant_name(variant) result(name)
        integer, intent(in) :: variant !! 0 .. variant_count
        character(len=:), allocatable :: name
        select case (variant)
        case (0)
            name = "plain (full Newton, working-precision LU, difference Hessians, fresh guess)"
        case (1)
            name = "plain + residual-difference Jacobian"
        case (2)
            name = "plain + exact Hessians"
        case (3)
            name = "plain + extrapolated guess"
        case (4)
            name = "plain + simplified Newton"
        case (5)
            name = "plain + mixed-precision LU"
        case (6)
            name = "plain + mixed LU + real64 pre-solve"
        case (7)
            name = "simplified + mixed + extrapolated (difference Hessians)"
        case (8)
            name = "fast without the real64 pre-solve"
        case default
            name = "the defaults (reduced step: all fast options)"
        end select
    end function variant_name

    !> Set the options of `integ` for option set `variant`, before its `init`: the sets
    !! 0 .. variant_count - 1 run the general step (`structured = .false.`, which honours
    !! each option alone), `variant_count` the defaults (the reduced step where the system
    !! allows it).
    subroutine configure_variant(integ, variant)
        type(constrained_integrator), intent(inout) :: integ !! the integrator
        integer, intent(in) :: variant !! 0 .. variant_count
        integ%structured = variant >= variant_count
        integ%newton%simplified = .false.
        integ%newton%presolve = .false.
        integ%linear_solver = "real128"
        if (wp_is_double) integ%linear_solver = "lapack"
        integ%jacobian = "assembled"
        integ%hessians = "differences"
        integ%extrapolate = .false.
        integ%linear_increments = .false.
        select case (variant)
        case (0)
        case (1)
            integ%jacobian = "residual-differences"
        case (2)
            integ%hessians = "user"
        case (3)
            integ%extrapolate = .true.
        case (4)
            integ%newton%simplified = .true.
        case (5)
            integ%linear_solver = "mixed"
        case (6)
            integ%linear_solver = "mixed"
            integ%newton%presolve = .true.
        case (7)
            integ%newton%simplified = .true.
            integ%linear_solver = "mixed"
            integ%extrapolate = .true.
        case (8)
            integ%newton%simplified = .true.
            integ%linear_solver = "mixed"
            integ%extrapolate = .true.
            integ%hessians = "user"
            integ%linear_increments = .true.
        case default
            integ%newton%simplified = .true.
            integ%linear_solver = "mixed"
            integ%newton%presolve = .true.
            integ%extrapolate = .true.
            integ%hessians = "automatic"
            integ%linear_increments = .true.
        end select
    end subroutine configure_variant

    !> Reference q(T), p(T): holosym M = 8 (order 16) with all fast options at h and h/2;
    !! `accuracy` = |run(h) - run(h/2)| / (2^16 - 1), the estimated error of the h/2 run.
    subroutine reference_state(sys, q0, p0, span, h, q_ref, p_ref, change, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:), p0(:) !! initial state
        real(wp), intent(in) :: span         !! T
        real(wp), intent(in) :: h            !! coarser step of the pair
        real(wp), intent(out) :: q_ref(:), p_ref(:) !! the h/2 run at T
        real(wp), intent(out) :: change      !! max |run(h) - run(h/2)|
        type(holosym_status_t), intent(out) :: status !! outcome
        type(bench_row_t) :: row
        real(wp) :: q1(size(q0)), p1(size(p0))
        call holosym_run(sys, q0, p0, span, 8, 7, 9, h, variant_count, q0, p0, .false., row, &
                         status, q1, p1)
        if (.not. status%ok()) return
        call holosym_run(sys, q0, p0, span, 8, 7, 9, h / 2, variant_count, q0, p0, .false., &
                         row, status, q_ref, p_ref)
        change = max(maxval(abs(q1 - q_ref)), maxval(abs(p1 - p_ref)))
    end subroutine reference_state

    !> Energy and constraint monitor over the steps of a run.
    subroutine monitor(sys, q, p, energy0, energy_error, constraint_residual)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), energy0
        real(wp), intent(inout) :: energy_error, constraint_residual
        real(wp) :: position, velocity
        energy_error = max(energy_error, abs((sys%hamiltonian(q, p) - energy0) / energy0))
        call manifold_residuals(sys, q, p, position, velocity)
        constraint_residual = max(constraint_residual, position, velocity)
    end subroutine monitor

    !> Median of three or one value.
    pure real(real64) function median(times, count)
        real(real64), intent(in) :: times(3)
        integer, intent(in) :: count
        if (count < 3) then
            median = times(1)
        else
            median = max(min(times(1), times(2)), min(max(times(1), times(2)), times(3)))
        end if
    end function median

    !> A finished run's error at T against the reference and the integrator's work counts.
    subroutine record_end(integ, q, p, q_ref, p_ref, row)
        type(constrained_integrator), intent(in) :: integ
        real(wp), intent(in) :: q(:), p(:), q_ref(:), p_ref(:)
        type(bench_row_t), intent(inout) :: row
        row%error = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
        row%newton_iterations = integ%stats%newton_iterations
        row%residuals = integ%stats%residual_evaluations
        row%gradients = integ%stats%gradient_evaluations
        row%hessians = integ%stats%hessian_evaluations
        row%factorizations = integ%stats%lu_factorizations
    end subroutine record_end

    !> One run as `holosym simulate --accuracy request --T span` makes it: `init_for_accuracy`
    !! (the pilot: (M, N, G), h and the Newton tolerance chosen for the request) then
    !! `integrate` with the plan. The row's method is holosym-accuracy, its tolerance the
    !! request, `compile_seconds` the pilot's CPU seconds and `seconds` the run's (each the
    !! median of 3 when pilot and run together are shorter than `short_run`).
    subroutine accuracy_run(sys, q0, p0, span, request, q_ref, p_ref, row, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:), p0(:)   !! initial state
        real(wp), intent(in) :: span           !! T
        real(wp), intent(in) :: request        !! the error asked for at T
        real(wp), intent(in) :: q_ref(:), p_ref(:) !! reference state at T
        type(bench_row_t), intent(out) :: row  !! the measurements
        type(holosym_status_t), intent(out) :: status !! outcome
        type(constrained_integrator) :: integ
        type(accuracy_plan_t) :: plan
        real(wp) :: q(size(q0)), p(size(p0))
        real(real64) :: pilot(3), run(3), start, planned, finish
        integer :: repeat, repeats
        row%method = "holosym-accuracy"
        row%precision = merge("real64 ", "real128", wp_is_double)
        row%tolerance = request
        repeats = 1
        repeat = 0
        do while (repeat < repeats)
            repeat = repeat + 1
            q = q0
            p = p0
            call cpu_time(start)
            call init_for_accuracy(integ, sys, q, p, request, span, plan, status)
            call cpu_time(planned)
            if (.not. status%ok()) exit
            call integ%integrate(sys, q, p, plan%h, plan%steps, status=status)
            call cpu_time(finish)
            if (.not. status%ok()) exit
            pilot(repeat) = planned - start
            run(repeat) = finish - planned
            if (repeat == 1 .and. finish - start < short_run) repeats = 3
        end do
        row%code = status%code
        row%order_m = plan%order_m
        row%order_n = plan%order_n
        row%gauss_points = plan%gauss_points
        row%order = 2 * plan%order_m
        row%h = plan%h
        row%steps = plan%steps
        if (.not. status%ok()) then
            row%h = span  ! no plan (e.g. a request below the round-off floor): a placeholder
            return
        end if
        row%compile_seconds = median(pilot, repeats)
        row%seconds = median(run, repeats)
        call record_end(integ, q, p, q_ref, p_ref, row)
    end subroutine accuracy_run

    !> One holosym run over [0, T] with step h and option set `variant`: a diagnostic pass
    !! (energy, constraints; optional, untimed) and timed passes of `integrate`.
    subroutine holosym_run(sys, q0, p0, span, order_m, order_n, gauss_points, h, variant, &
                           q_ref, p_ref, diagnose, row, status, q_end, p_end, newton_tolerance)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:), p0(:)   !! initial state
        real(wp), intent(in) :: span           !! T
        integer, intent(in) :: order_m, order_n, gauss_points !! (M, N, G)
        real(wp), intent(in) :: h              !! requested step (rounded to T / steps)
        integer, intent(in) :: variant         !! option set
        real(wp), intent(in) :: q_ref(:), p_ref(:) !! reference state at T
        logical, intent(in) :: diagnose        !! run the diagnostic pass
        type(bench_row_t), intent(out) :: row  !! the measurements
        type(holosym_status_t), intent(out) :: status !! outcome
        real(wp), intent(out), optional :: q_end(:), p_end(:) !! state at T
        !> Newton tolerance (> 0), recorded as the row's `tolerance`; else the default.
        real(wp), intent(in), optional :: newton_tolerance
        type(constrained_integrator) :: integ
        real(wp) :: q(size(q0)), p(size(p0)), energy0, step_size
        real(real64) :: times(3), start, finish
        integer :: k, steps, repeat, repeats

        steps = max(1, nint(span / h))
        step_size = span / steps
        row%order_m = order_m
        row%order_n = order_n
        row%gauss_points = gauss_points
        row%order = 2 * order_m
        row%h = step_size
        row%steps = steps
        row%method = "holosym"
        if (variant == 0) row%method = "holosym-plain"
        if (present(newton_tolerance)) row%tolerance = max(newton_tolerance, 0.0_wp)
        row%precision = merge("real64 ", "real128", wp_is_double)
        if (diagnose) then
            q = q0
            p = p0
            call configure_variant(integ, variant)
            call integ%init(sys, order_m, order_n, gauss_points, status)
            if (.not. status%ok()) then
                row%code = status%code
                return
            end if
            if (present(newton_tolerance)) then
                if (newton_tolerance > 0) then
                    ! States then meet the constraints to about this tolerance: accept them
                    ! as start states of the next call (the diagnostic pass steps singly).
                    integ%newton%tolerance = newton_tolerance
                    integ%manifold_tolerance = max(integ%manifold_tolerance, &
                                                   1.0e4_wp * newton_tolerance)
                end if
            end if
            energy0 = sys%hamiltonian(q, p)
            do k = 1, steps
                call integ%integrate(sys, q, p, step_size, 1, status=status)
                if (.not. status%ok()) then
                    row%code = status%code
                    return
                end if
                call monitor(sys, q, p, energy0, row%energy_error, row%constraint_residual)
            end do
        end if
        repeats = 1
        repeat = 0
        do while (repeat < repeats)
            repeat = repeat + 1
            q = q0
            p = p0
            call configure_variant(integ, variant)
            call integ%init(sys, order_m, order_n, gauss_points, status)
            if (.not. status%ok()) exit
            if (present(newton_tolerance)) then
                if (newton_tolerance > 0) then
                    ! States then meet the constraints to about this tolerance: accept them
                    ! as start states of the next call (the diagnostic pass steps singly).
                    integ%newton%tolerance = newton_tolerance
                    integ%manifold_tolerance = max(integ%manifold_tolerance, &
                                                   1.0e4_wp * newton_tolerance)
                end if
            end if
            call cpu_time(start)
            call integ%integrate(sys, q, p, step_size, steps, status=status)
            call cpu_time(finish)
            if (.not. status%ok()) exit
            times(repeat) = finish - start
            if (repeat == 1 .and. times(1) < short_run) repeats = 3
        end do
        row%code = status%code
        if (.not. status%ok()) return
        row%seconds = median(times, repeats)
        call record_end(integ, q, p, q_ref, p_ref, row)
        if (present(q_end)) q_end = q
        if (present(p_end)) p_end = p
    end subroutine holosym_run

    !> One run of RATTLE composed to `order` (family 'triple-jump' or 'suzuki').
    subroutine rattle_run(sys, q0, p0, span, order, family, h, q_ref, p_ref, row, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system (separable)
        real(wp), intent(in) :: q0(:), p0(:)   !! initial state
        real(wp), intent(in) :: span           !! T
        integer, intent(in) :: order           !! 2, 4, 6, 8, 10
        character(len=*), intent(in) :: family !! composition family
        real(wp), intent(in) :: h              !! requested step (rounded to T / steps)
        real(wp), intent(in) :: q_ref(:), p_ref(:) !! reference state at T
        type(bench_row_t), intent(out) :: row  !! the measurements
        type(holosym_status_t), intent(out) :: status !! outcome
        type(rattle_integrator) :: rattle
        real(wp) :: q(size(q0)), p(size(p0)), energy0, step_size
        real(real64) :: times(3), start, finish
        integer :: k, steps, repeat, repeats

        steps = max(1, nint(span / h))
        step_size = span / steps
        row%order = order
        row%h = step_size
        row%steps = steps
        row%method = "rattle-" // family
        row%precision = merge("real64 ", "real128", wp_is_double)
        q = q0
        p = p0
        call rattle%init(sys, order, family, status)
        if (.not. status%ok()) then
            row%code = status%code
            return
        end if
        rattle%separable = .true.
        energy0 = sys%hamiltonian(q, p)
        do k = 1, steps
            call rattle%step(sys, q, p, step_size, status)
            if (.not. status%ok()) then
                row%code = status%code
                return
            end if
            call monitor(sys, q, p, energy0, row%energy_error, row%constraint_residual)
        end do
        repeats = 1
        repeat = 0
        do while (repeat < repeats)
            repeat = repeat + 1
            q = q0
            p = p0
            call rattle%init(sys, order, family, status)
            rattle%separable = .true.
            call cpu_time(start)
            call rattle%integrate(sys, q, p, step_size, steps, status)
            call cpu_time(finish)
            if (.not. status%ok()) exit
            times(repeat) = finish - start
            if (repeat == 1 .and. times(1) < short_run) repeats = 3
        end do
        row%code = status%code
        if (.not. status%ok()) return
        row%seconds = median(times, repeats)
        row%error = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
        row%newton_iterations = rattle%stats%newton_iterations
        row%gradients = rattle%stats%gradient_evaluations
        row%hessians = rattle%stats%hessian_evaluations
        row%factorizations = rattle%stats%lu_factorizations
    end subroutine rattle_run

    !> Sweep h geometrically for one holosym configuration, from `h0` down, until the error
    !! reaches the floor, stops decreasing twice, a run exceeds the budget or fails twice.
    subroutine sweep_holosym(sys, system, q0, p0, order_m, order_n, gauss_points, h0, &
                             q_ref, p_ref, settings, rows)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        character(len=*), intent(in) :: system !! its name
        real(wp), intent(in) :: q0(:), p0(:)   !! initial state
        integer, intent(in) :: order_m, order_n, gauss_points !! (M, N, G)
        real(wp), intent(in) :: h0             !! largest step
        real(wp), intent(in) :: q_ref(:), p_ref(:) !! reference at T
        type(bench_settings_t), intent(in) :: settings !! limits
        type(bench_row_t), allocatable, intent(inout) :: rows(:) !! rows are appended
        call sweep(.true., order_m, order_n, gauss_points, 0, "", sys, system, q0, p0, h0, &
                   q_ref, p_ref, settings, rows)
    end subroutine sweep_holosym

    !> Sweep h for RATTLE composed to `order` (see `sweep_holosym`).
    subroutine sweep_rattle(sys, system, q0, p0, order, family, h0, q_ref, p_ref, settings, &
                            rows)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        character(len=*), intent(in) :: system !! its name
        real(wp), intent(in) :: q0(:), p0(:)   !! initial state
        integer, intent(in) :: order           !! composition order
        character(len=*), intent(in) :: family !! composition family
        real(wp), intent(in) :: h0             !! largest step
        real(wp), intent(in) :: q_ref(:), p_ref(:) !! reference at T
        type(bench_settings_t), intent(in) :: settings !! limits
        type(bench_row_t), allocatable, intent(inout) :: rows(:) !! rows are appended
        call sweep(.false., 0, 0, 0, order, family, sys, system, q0, p0, h0, q_ref, p_ref, &
                   settings, rows)
    end subroutine sweep_rattle

    subroutine sweep(is_holosym, order_m, order_n, gauss_points, order, family, sys, system, &
                     q0, p0, h0, q_ref, p_ref, settings, rows)
        logical, intent(in) :: is_holosym
        integer, intent(in) :: order_m, order_n, gauss_points, order
        character(len=*), intent(in) :: family, system
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), h0, q_ref(:), p_ref(:)
        type(bench_settings_t), intent(in) :: settings
        type(bench_row_t), allocatable, intent(inout) :: rows(:)
        type(bench_row_t) :: row
        type(holosym_status_t) :: status
        real(wp) :: span, best
        integer :: level, steps, last_steps, no_gain, failures
        span = bench_span(system)
        best = huge(1.0_wp)
        last_steps = 0
        no_gain = 0
        failures = 0
        do level = 0, settings%max_levels
            steps = max(1, nint(span / h0 * settings%refinement**level))
            if (steps == last_steps) cycle
            last_steps = steps
            if (is_holosym) then
                call holosym_run(sys, q0, p0, span, order_m, order_n, gauss_points, &
                                 span / steps, variant_count, q_ref, p_ref, .true., row, status, &
                                 newton_tolerance=settings%newton_tolerance)
            else
                call rattle_run(sys, q0, p0, span, order, family, span / steps, q_ref, p_ref, &
                                row, status)
            end if
            row%system = system
            if (settings%progress_unit >= 0) call progress_line(settings, system, row, &
                order_m, order_n, gauss_points, steps, status)
            rows = [rows, row]
            ! Step sizes the integrator refuses as too large to resolve the motion are
            ! passed over until a run succeeds; other failures end the sweep at the third.
            if (row%code == HOLOSYM_STEP_TOO_LARGE .and. best == huge(1.0_wp)) cycle
            if (row%code /= HOLOSYM_SUCCESS) then
                failures = failures + 1
                if (failures >= 3) exit
                cycle
            end if
            if (row%seconds > settings%budget .or. row%error <= settings%error_floor) exit
            if (row%error >= 0.9_wp * best) then
                no_gain = no_gain + 1
                if (no_gain >= 2) exit
            else
                no_gain = 0
            end if
            best = min(best, row%error)
        end do
    end subroutine sweep

    !> The progress line of one run of a sweep: which sweep of how many, the time, the run
    !! and its error, or why it failed.
    subroutine progress_line(settings, system, row, order_m, order_n, gauss_points, steps, &
                             status)
        type(bench_settings_t), intent(in) :: settings
        character(len=*), intent(in) :: system
        type(bench_row_t), intent(in) :: row
        integer, intent(in) :: order_m, order_n, gauss_points, steps
        type(holosym_status_t), intent(in) :: status
        character(len=:), allocatable :: run, outcome
        run = trim(system) // " " // trim(row%method) // " order " // int_str(row%order) // &
            " (" // int_str(order_m) // "," // int_str(order_n) // "," // &
            int_str(gauss_points) // ") steps " // int_str(steps) // ": "
        if (row%code == HOLOSYM_SUCCESS) then
            outcome = "error " // real_str(row%error) // ", " // &
                real_str(real(row%seconds, wp)) // " s"
        else
            outcome = "failed: " // status_code_name(row%code)
            if (allocated(status%message)) then
                if (len(status%message) > 0) outcome = outcome // ": " // status%message
            end if
        end if
        call settings%clock%report(settings%progress_unit, "bench: ", settings%sweep, &
                                   settings%sweep - 1, settings%sweeps, run // outcome)
    end subroutine progress_line

end module holosym_benchmark

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_benchmark) holosym_benchmark_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_benchmark_app
