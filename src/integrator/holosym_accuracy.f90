!> category: public module (use holosym)
!! The trade of speed for accuracy as one argument: `init_for_accuracy` chooses the scheme
!! (M, N, G), the step size h and the Newton tolerance for a requested global error at
!! time T, from the error model of the scheme and a short pilot, and sets up the
!! integrator with them.
!!
!! Error model. The method has order 2M: the error of one run to T with step h is about
!! C T h^(2M) for regular motion (phase errors grow linearly in time). The pilot first
!! finds a step in the asymptotic range on the first tenth of the span: runs with steps
!! h_p, h_p/2, h_p/4 (h_p the whole tenth at first), whose differences d1, d2 have the
!! ratio 2^(2M) there (h_p is halved until d1/d2 is at least a quarter of it, or a run
!! fails). It then measures the error constant over the span itself (its first 1000
!! coarse steps when longer): runs with 2 h and h (h the finest pilot step) whose
!! difference d gives the error of the finer, d / (2^(2M) - 1), extrapolated linearly to
!! T; these two runs iterate Newton only to a tolerance derived from the request. The
!! whole span is needed: a motion that starts slowly (the spring-linkage, released
!! at rest) has errors after the first tenth orders of magnitude below those at T. The
!! step is chosen to meet half the request (never coarser than the coarsest step the
!! search found asymptotic, twice the coarse span run's),
!! rounded so that T is a whole number of steps; the Newton tolerance is the request
!! spread over the steps (at least 8 epsilon): a loose request needs no
!! working-precision residual at all. docs/accuracy.md has the measurements.
!!
!! What the model cannot see: motion whose errors grow faster than linearly between the
!! span measured and T (chaos, a separatrix); requests below the round-off of the working
!! precision (`accuracy_floor`) are refused.
module holosym_accuracy
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, set_status, real_str, int_str, &
        is_finite, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SIZE_MISMATCH
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_newton, only: default_newton_tolerance
    implicit none
    private

    public :: accuracy_plan_t, init_for_accuracy, accuracy_floor

    !> What `init_for_accuracy` chose, and why.
    type :: accuracy_plan_t
        integer :: order_m = 0, order_n = 0, gauss_points = 0 !! the scheme (M, N, G)
        real(wp) :: h = 0                 !! step size: T / steps
        integer :: steps = 0              !! steps to T
        real(wp) :: newton_tolerance = 0  !! the integrator's `newton%tolerance`
        real(wp) :: estimate = 0          !! predicted max |error| of q and p at T
        real(wp) :: pilot_h = 0           !! finest step of the pilot
        real(wp) :: pilot_span = 0        !! span of the pilot's search for the asymptotic step
        real(wp) :: covered_span = 0      !! span of the runs that measured the error constant
        real(wp) :: observed_ratio = 0    !! d1 / d2 of the pilot (2^(2M) when asymptotic)
        integer :: pilot_steps = 0        !! steps the pilot took, all runs together
    end type accuracy_plan_t

    !> Share of the span over which the pilot finds the asymptotic step.
    real(wp), parameter :: pilot_fraction = 0.1_wp
    !> The error constant is measured over the span, or over its first this many coarse
    !! pilot steps when it is longer (a long run's error is extrapolated linearly from
    !! there: the pilot then costs a bounded fraction of the run).
    integer, parameter :: span_steps = 1000
    !> ... and its coarse step is halved at most this many times when a run fails there.
    integer, parameter :: span_halvings = 4
    !> The search for the asymptotic step runs at most this many coarse steps (from the
    !! start) per step size tried: its span shrinks with the step beyond.
    integer, parameter :: pilot_steps_max = 4
    !> Halvings of the pilot step tried before the pilot gives up on the asymptotic regime
    !! (the first tenth of the span over 2^40 at the last).
    integer, parameter :: pilot_halvings = 40
    !> The pilot differences are asymptotic when their ratio is at least this share of
    !! 2^(2M) (the next term of the error expansion, and the first steps' transient, move
    !! it a little).
    real(wp), parameter :: asymptotic_share = 0.25_wp
    !> The plan aims at the request divided by this (the estimate varies by a few per cent
    !! with the pilot, the linear growth in time by more).
    real(wp), parameter :: safety = 2
    !> Pilot differences below this many epsilons of the state's size are round-off: the
    !! coarser difference then bounds the error.
    real(wp), parameter :: roundoff_epsilons = 1000
    !> The most steps a plan may take (the step counter of `integrate` is a default
    !! integer).
    integer, parameter :: max_steps = huge(1) / 2
    !> The Newton tolerance is the request over this many times the steps (per-step Newton
    !! errors add up at most linearly).
    real(wp), parameter :: newton_share = 4
    !> The pilot's span runs keep their Newton errors this many times below the request
    !! (the difference they measure is 2^(2M) - 1 times the error of the finer, and the
    !! plan's step is at most twice the coarser's).
    real(wp), parameter :: span_share = 64

contains

    !> The smallest request `init_for_accuracy` accepts for a state of size `scale`: the
    !! round-off of a run of some thousand steps in the working precision (100 epsilons of
    !! the state; 2e-32 in real128, 2e-14 in real64, for a state of size 1).
    pure real(wp) function accuracy_floor(scale)
        real(wp), intent(in) :: scale !! max(|q|, |p|) of the start state
        accuracy_floor = 100 * epsilon(1.0_wp) * max(scale, 1.0_wp)
    end function accuracy_floor

    !> Set up `integ` to reach `tolerance` (max |error| of q and p at T, absolute) at time
    !! T from (q, p), which stay unchanged: the plan in `plan`; then
    !! `call integ%integrate(sys, q, p, plan%h, plan%steps, ...)`. Codes:
    !! HOLOSYM_INVALID_ARGUMENT (tolerance not in [accuracy_floor, 1), T not > 0 and
    !! finite), HOLOSYM_SIZE_MISMATCH, or the failure of a pilot run (the code of its step;
    !! the message says which pilot step). On failure `integ` is unchanged and `plan` holds
    !! what the pilot found.
    subroutine init_for_accuracy(integ, sys, q, p, tolerance, T, plan, status)
        type(constrained_integrator), intent(inout) :: integ !! set up for the plan
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(in) :: q(:), p(:)   !! start state (on the constraints)
        real(wp), intent(in) :: tolerance    !! requested max |error| at T
        real(wp), intent(in) :: T            !! final time, > 0
        type(accuracy_plan_t), intent(out) :: plan !! the choice and its estimate
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(constrained_integrator) :: trial, fresh
        type(holosym_status_t) :: local
        real(wp) :: scale, error_full, h_full, h

        scale = 0
        if (size(q) == sys%n .and. size(p) == sys%n .and. sys%n > 0) &
            scale = max(maxval(abs(q)), maxval(abs(p)))
        if (.not. request_valid(sys, q, p, tolerance, T, scale, local)) then
            call set_status(status, local%code, local%message)
            return
        end if
        call choose_order(tolerance, plan)
        plan%pilot_span = pilot_fraction * T
        ! The pilot runs on a copy (the caller's integrator changes only with a plan), one
        ! set-up for every run (each starts afresh from (q, p)); the system is checked
        ! (when the integrator checks systems) by the first run only.
        trial = integ
        trial%newton%tolerance = default_newton_tolerance
        call trial%init(sys, plan%order_m, plan%order_n, plan%gauss_points, local)
        ! The plan's integrator is this set-up, untouched by the pilot's runs (a second
        ! `init` would repeat the scheme's construction, as costly as some steps).
        fresh = trial
        if (local%ok()) call search(trial, sys, q, p, plan, scale, local)
        if (local%ok()) call full_span(trial, sys, q, p, T, tolerance, plan, scale, &
                                       error_full, h_full, local)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        ! Error at T ~ error_full (h / h_full)^(2M): meet tolerance / safety, with steps no
        ! coarser than the coarsest the search found asymptotic (4 pilot_h, twice the
        ! coarse span run's).
        h = h_full * (tolerance / (safety * error_full))**(1.0_wp / (2 * plan%order_m))
        h = min(h, 4 * plan%pilot_h)
        if (T / h > max_steps) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "the plan for " // &
                real_str(tolerance) // " at T = " // real_str(T) // " needs " // &
                real_str(T / h) // " steps, more than " // int_str(max_steps) // &
                ": ask for less accuracy or a shorter T")
            return
        end if
        plan%steps = max(1, ceiling(T / h))
        plan%h = T / plan%steps
        plan%estimate = error_full * (plan%h / h_full)**(2 * plan%order_m)
        plan%newton_tolerance = max(default_newton_tolerance, min(1.0e-3_wp, &
            tolerance / (newton_share * plan%steps * max(scale, 1.0_wp))))
        fresh%newton%tolerance = plan%newton_tolerance
        integ = fresh
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine init_for_accuracy

    !> Pilot differences at or below this are round-off of a state of size `scale`.
    pure real(wp) function roundoff_floor(scale)
        real(wp), intent(in) :: scale !! max(|q|, |p|) of the start state
        roundoff_floor = roundoff_epsilons * epsilon(1.0_wp) * max(scale, 1.0_wp)
    end function roundoff_floor

    !> Whether the request is one `init_for_accuracy` can plan; else why not.
    logical function request_valid(sys, q, p, tolerance, T, scale, status) result(valid)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), tolerance, T, scale
        type(holosym_status_t), intent(out) :: status
        valid = .false.
        status%code = HOLOSYM_SUCCESS
        if (size(q) /= sys%n .or. size(p) /= sys%n) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q and p must have size " // &
                int_str(sys%n))
        else if (.not. (is_finite(T) .and. is_finite(tolerance))) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tolerance and T must be " // &
                "finite, got " // real_str(tolerance) // " and " // real_str(T))
        else if (T <= 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "T must be > 0, got " // &
                real_str(T))
        else if (tolerance >= 1 .or. tolerance < accuracy_floor(scale)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tolerance must be in [" // &
                real_str(accuracy_floor(scale)) // ", 1) (the round-off of the working " // &
                "precision for this state), got " // real_str(tolerance))
        else
            valid = .true.
        end if
    end function request_valid

    !> (M, N, G) for a request: order 16 (M = 8) where the bench finds it the fastest in
    !! real128 (1e-14 and tighter), order 12 (M = 6) down from 1e-10, order 8 (M = 4)
    !! for looser requests (steps of a size the motion still resolves); N = M - 1,
    !! G = M + 1 (the paper's best family).
    pure subroutine choose_order(tolerance, plan)
        real(wp), intent(in) :: tolerance
        type(accuracy_plan_t), intent(inout) :: plan
        plan%order_m = 8
        if (tolerance > 1.0e-13_wp .or. wp_is_double) plan%order_m = 6
        if (tolerance > 1.0e-9_wp) plan%order_m = 4
        plan%order_n = plan%order_m - 1
        plan%gauss_points = plan%order_m + 1
    end subroutine choose_order

    !> The pilot's search for the asymptotic step (`pilot`), first without the general
    !! step's fallback after a failed reduced step: the steps too large for the motion
    !! that the search begins with fail at the cost of the reduced iteration alone. Only
    !! when no step size passes that way is the search repeated with the integrator's
    !! setting (a system that only the general step solves).
    subroutine search(integ, sys, q, p, plan, scale, status)
        type(constrained_integrator), intent(inout) :: integ
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), scale
        type(accuracy_plan_t), intent(inout) :: plan
        type(holosym_status_t), intent(out) :: status
        logical :: fallback
        real(wp) :: span
        fallback = integ%general_fallback
        span = plan%pilot_span
        integ%general_fallback = .false.
        call pilot(integ, sys, q, p, plan, scale, status)
        integ%general_fallback = fallback
        if (status%ok() .or. .not. fallback) return
        plan%pilot_span = span
        call pilot(integ, sys, q, p, plan, scale, status)
    end subroutine search

    !> The pilot's search for the asymptotic step: runs with steps h_p, h_p/2, h_p/4 from
    !! the start (h_p halved until their differences shrink as h^(2M), or the finest run is
    !! exact to round-off); the finest step in `plan%pilot_h`.
    subroutine pilot(integ, sys, q, p, plan, scale, status)
        type(constrained_integrator), intent(inout) :: integ
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), scale
        type(accuracy_plan_t), intent(inout) :: plan
        type(holosym_status_t), intent(out) :: status
        real(wp), allocatable :: end(:, :)
        real(wp) :: d1, d2, h_coarse, pilot_span_max
        integer :: halving, steps, k

        allocate (end(2 * sys%n, 3))
        pilot_span_max = plan%pilot_span
        do halving = 0, pilot_halvings
            ! Coarse step h_c = T_pilot / 2^halving over min(2^halving, pilot_steps_max)
            ! of its steps: the span of the test shrinks with h_c once it has that many.
            h_coarse = pilot_span_max / 2.0_wp**halving
            steps = min(2**min(halving, 30), pilot_steps_max)
            plan%pilot_span = steps * h_coarse
            plan%pilot_h = h_coarse / 4
            ! A step too large for Newton or the root check is one the motion does not
            ! resolve yet: halve it.
            do k = 1, 3
                call pilot_run(integ, sys, q, p, plan, plan%pilot_span, steps * 2**(k - 1), &
                               end(:, k), status)
                if (.not. status%ok()) exit
            end do
            ! (Also a NaN of the system's procedures: at a step far too large the iterates
            ! leave any domain; a fault at every step size ends the search with its code.)
            if (.not. status%ok()) cycle
            d1 = maxval(abs(end(:, 1) - end(:, 2)))
            d2 = maxval(abs(end(:, 2) - end(:, 3)))
            if (d2 <= roundoff_floor(scale)) then
                ! The finest run is exact to round-off: this step resolves the motion.
                plan%observed_ratio = 0
                return
            end if
            plan%observed_ratio = d1 / d2
            if (plan%observed_ratio >= asymptotic_share * 2.0_wp**(2 * plan%order_m)) return
        end do
        if (.not. status%ok()) return
        call set_status(status, HOLOSYM_INVALID_ARGUMENT, "the pilot found no step size " // &
            "down to " // real_str(plan%pilot_h) // " where the errors shrink as h^" // &
            int_str(2 * plan%order_m) // " (last ratio " // real_str(plan%observed_ratio) // &
            "): the motion is not resolved on the first " // real_str(plan%pilot_span) // &
            " of the span")
    end subroutine pilot

    !> The error at T: runs over the span (at most `span_steps` coarse steps of it) with
    !! the coarse step h_c = 2 pilot_h and with h_c/2, their difference d giving the error
    !! of the finer, d / (2^(2M) - 1), extrapolated linearly from the span covered to T; in
    !! `error` at step `h_fine` (h_c halved while a run fails: the motion may be faster
    !! later than at the start). The two runs iterate Newton to `span_tolerance` (their
    !! Newton errors, added over the steps, far below the request), not to round-off.
    subroutine full_span(integ, sys, q, p, T, tolerance, plan, scale, error, h_fine, status)
        type(constrained_integrator), intent(inout) :: integ
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), T, scale
        real(wp), intent(in) :: tolerance !! the request
        type(accuracy_plan_t), intent(inout) :: plan
        real(wp), intent(out) :: error, h_fine
        type(holosym_status_t), intent(out) :: status
        real(wp), allocatable :: end(:, :)
        real(wp) :: d, covered, coarse
        integer :: halving, steps
        allocate (end(2 * sys%n, 2))
        coarse = 2 * plan%pilot_h
        error = 0
        h_fine = 0
        do halving = 0, span_halvings
            ! The whole span, or its first `span_steps` coarse steps.
            covered = T
            if (T / coarse > span_steps) then
                steps = span_steps
                covered = span_steps * coarse
            else
                steps = max(1, ceiling(T / coarse))
            end if
            integ%newton%tolerance = span_tolerance(tolerance, 2 * steps, scale)
            call pilot_run(integ, sys, q, p, plan, covered, steps, end(:, 1), status)
            if (status%ok()) call pilot_run(integ, sys, q, p, plan, covered, 2 * steps, &
                                            end(:, 2), status)
            if (status%ok()) exit
            coarse = coarse / 2
        end do
        if (.not. status%ok()) return
        h_fine = covered / (2 * steps)
        plan%covered_span = covered
        d = maxval(abs(end(:, 1) - end(:, 2)))
        ! At round-off, or at the runs' Newton errors, the difference bounds the error
        ! from above.
        error = max(d, roundoff_floor(scale), newton_floor(integ%newton%tolerance, &
            2 * steps, scale)) / (2.0_wp**(2 * plan%order_m) - 1) * (T / covered)
        integ%newton%tolerance = default_newton_tolerance
    end subroutine full_span

    !> The Newton tolerance of the span runs for a request: their Newton errors, at most
    !! `steps` times the tolerance of the state's size, stay `span_share` times below it
    !! (at least 8 epsilon, the default).
    pure real(wp) function span_tolerance(tolerance, steps, scale)
        real(wp), intent(in) :: tolerance, scale
        integer, intent(in) :: steps
        span_tolerance = max(default_newton_tolerance, min(1.0e-3_wp, &
            tolerance / (span_share * steps * max(scale, 1.0_wp))))
    end function span_tolerance

    !> The most the Newton errors of a run of `steps` steps at Newton tolerance
    !! `newton_tolerance` move its end state (0 at the default 8 epsilon: round-off
    !! bounds them then).
    pure real(wp) function newton_floor(newton_tolerance, steps, scale)
        real(wp), intent(in) :: newton_tolerance, scale
        integer, intent(in) :: steps
        newton_floor = 0
        if (newton_tolerance > default_newton_tolerance) &
            newton_floor = steps * newton_tolerance * max(scale, 1.0_wp)
    end function newton_floor

    !> One pilot run: `steps` steps to `span` with `integ` as set up for the pilot (the
    !! plan's (M, N, G) and the Newton tolerance it is given); the end state in `end`.
    subroutine pilot_run(integ, sys, q, p, plan, span, steps, end, status)
        type(constrained_integrator), intent(inout) :: integ
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), span
        type(accuracy_plan_t), intent(inout) :: plan
        integer, intent(in) :: steps
        real(wp), intent(out) :: end(:)
        type(holosym_status_t), intent(out) :: status
        real(wp) :: qk(size(q)), pk(size(p))
        qk = q
        pk = p
        call integ%integrate(sys, qk, pk, span / steps, steps, status=status)
        plan%pilot_steps = plan%pilot_steps + steps
        if (.not. status%ok()) then
            status%message = "pilot run of " // int_str(steps) // " steps to " // &
                real_str(span) // ": " // status%message
            return
        end if
        end(1:size(q)) = qk
        end(size(q) + 1:) = pk
    end subroutine pilot_run

end module holosym_accuracy
