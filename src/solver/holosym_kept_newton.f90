!> category: internal module (use holosym)
!! Simplified Newton on kept real64 factors, for a `nonlinear_system` whose Newton matrix
!! is cheap to form in real64 and worth keeping across solves (the iteration of the
!! reduced step; it solves the general scheme too):
!! - the Newton matrix is formed by the system (`factor_matrix`, dense or banded
!!   `real64_factors_t`) from its last evaluation, and kept across iterations and solves
!!   while it contracts well;
!! - in real128 the first iterations use the real64 residual (`residual_dp`) to about
!!   1e-13 (`banded_phase_tolerance`), then the working-precision residual to the
!!   requested tolerance;
!! - the last correction is applied without a confirming residual when the contraction
!!   rate says the result is within the tolerance: the caller then updates what it derives
!!   from the last evaluation to first order across `state%delta` (`state%ended_lowered`
!!   says which evaluation that was);
!! - with `approximate`, a solve iterates first with the system's approximate matrix
!!   (`factor_approximate`, formed afresh at each solve's first guess: cheap, no second
!!   derivatives), as long as it contracts by `approximate_contraction_limit` per
!!   iteration; beyond, it is formed again at the current iterate once, and then replaced
!!   by the Newton matrix at the current iterate; at the
!!   end of the real64 phase the Newton matrix replaces it when that pays
!!   (`renewal_pays`, as for kept factors). After a switch for weak contraction, solves
!!   use the Newton matrix and try the approximate one every `retry_approximate_every`
!!   solves (`state%ended_approximate` says which matrix gave the last correction).
!! Its decisions and constants are those of `holosym_newton_policy`, shared with
!! `newton_solve`; the settings are `newton_settings_t`'s.
module holosym_kept_newton
    ! The intrinsic classification (inlined; at module level it adds no per-call
    ! floating-point state handling) for the checks inside every iteration.
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use holosym_kinds, only: wp, dp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED
    use holosym_factors, only: real64_factors_t
    use holosym_newton, only: nonlinear_system, newton_settings_t, contraction_limit_of, &
        jacobian_cost_of, fits_real64
    use holosym_newton_policy, only: next_action, predicted_within, renewal_pays, rate_margin, &
        retry_kept_every, banded_contraction_limit, banded_jacobian_cost, &
        banded_phase_tolerance, banded_phase_floor, remeasure_every, &
        approximate_contraction_limit, retry_approximate_every, approximate_tolerance_factor, &
        ACTION_ITERATE, &
        ACTION_CONVERGED, ACTION_REFACTOR, ACTION_DIVERGED
    implicit none
    private

    public :: kept_newton_t, kept_report_t, kept_newton_solve

    !> The iteration's state across solves: the kept factors, what earlier solves taught
    !! about them, and the workspace.
    type :: kept_newton_t
        type(real64_factors_t) :: factors
        !> Kept factors proved too stale: form fresh ones at each solve's first guess (tried
        !! again every `retry_kept_every` solves).
        logical :: prefer_fresh = .false.
        integer :: fresh_streak = 0
        !> The approximate matrix contracted too weakly: solves use the Newton matrix (the
        !! approximate one is tried again every `retry_approximate_every` solves).
        logical :: prefer_newton = .false.
        integer :: newton_streak = 0
        !> Contraction of factors formed at the end of the real64 phase, as measured by the
        !! working-precision corrections (1: not measured yet). Lets a solve accept its first
        !! working-precision correction when that is predicted to meet the tolerance.
        real(wp) :: learned_rate = 1
        integer :: steps_since_measured = 0
        !> The last correction applied (real64) and whether the evaluation before it was the
        !! real64 residual: what the caller updates its results across.
        real(dp), allocatable :: delta(:)
        logical :: ended_lowered = .false.
        !> The last correction came from the approximate matrix (else the Newton matrix).
        logical :: ended_approximate = .false.
        !> The iterate at which the Newton matrix was last found singular during the last
        !! solve (valid when `have_singular_x`): where the equations may be dependent.
        logical :: have_singular_x = .false.
        real(wp), allocatable :: singular_x(:)
        real(wp), allocatable :: f(:)
        real(dp), allocatable :: x_low(:), f_low(:)
    contains
        !> Allocate for nx unknowns and a Newton matrix of bandwidths (kl, ku).
        procedure :: setup => kept_setup
        !> Forget the kept factors and what earlier solves taught about them.
        procedure :: forget => kept_forget
        !> Drop the kept factors (e.g. a new step size); what was learnt stays.
        procedure :: invalidate => kept_invalidate
    end type kept_newton_t

    !> Work of one solve.
    type :: kept_report_t
        integer :: iterations = 0            !! Newton iterations (residuals solved with)
        integer :: factorizations = 0        !! Newton matrices formed and factored
        integer :: approximate = 0           !! iterations with the approximate matrix
    end type kept_report_t

    !> What one solve carries between its iterations and the procedures they call.
    type :: solve_t
        type(newton_settings_t) :: settings !! Newton's settings
        real(wp) :: scale = 1       !! size of the state (corrections are relative to it)
        real(wp) :: stagnation = 0  !! round-off floor of the working-precision corrections
        !> First working-precision correction after the real64 phase (0: none yet), and
        !! whether the first corrections are being watched (`first_corrections`).
        real(wp) :: first = 0
        logical :: watch = .false.
        !> Factors were renewed at the end of the real64 phase.
        logical :: renewed = .false.
        !> Contraction of the kept factors measured in the real64 phase (1: none).
        real(wp) :: low_rate = 1
        !> The corrections come from the system's approximate matrix, and it has been
        !! formed again in this solve after a poor contraction.
        logical :: approximate = .false.
        logical :: approximate_renewed = .false.
    end type solve_t

    !> The corrections of the current phase of one solve, for its decisions (`decide`).
    type :: progress_t
        logical :: lowered = .false.          !! the real64 phase (real128 build)
        real(wp) :: previous = huge(1.0_wp)   !! the last correction (huge: none yet)
        real(wp) :: last_rate = 0             !! its ratio to the one before (0: none)
        integer :: growth = 0                 !! growing corrections in a row
        logical :: fresh = .false.            !! the factors were formed at this iterate
        real(wp) :: target = 0, floor = 0     !! the phase's tolerance and round-off floor
        real(wp) :: limit = 0                 !! contraction limit of the Newton matrix
        real(wp) :: approximate_limit = 0     !! and of the approximate matrix
    end type progress_t

contains

    !> Allocate for nx unknowns and bandwidths (kl, ku) of the Newton matrix (dense storage
    !! when banded would not be cheaper, `real64_factors_t%setup`); forgets everything.
    subroutine kept_setup(self, nx, kl, ku)
        class(kept_newton_t), intent(inout) :: self
        integer, intent(in) :: nx, kl, ku !! unknowns, sub- and superdiagonals
        call self%factors%setup(nx, kl, ku)
        if (allocated(self%delta)) deallocate (self%delta, self%singular_x, self%f, &
                                               self%x_low, self%f_low)
        allocate (self%delta(nx), self%singular_x(nx), self%f(nx), self%x_low(nx), &
                  self%f_low(nx))
        call self%forget()
    end subroutine kept_setup

    !> Forget the kept factors and what earlier solves taught: the next solves then depend
    !! only on their own inputs.
    subroutine kept_forget(self)
        class(kept_newton_t), intent(inout) :: self
        self%factors%factored = .false.
        self%prefer_fresh = .false.
        self%fresh_streak = 0
        self%prefer_newton = .false.
        self%newton_streak = 0
        self%learned_rate = 1
        self%steps_since_measured = 0
    end subroutine kept_forget

    !> Drop the kept factors.
    elemental subroutine kept_invalidate(self)
        class(kept_newton_t), intent(inout) :: self
        self%factors%factored = .false.
    end subroutine kept_invalidate

    !> Solve F(x) = 0 from the first guess in x by simplified Newton on kept factors (see
    !! the module's description). `settings`: `tolerance` bounds the error relative to
    !! `scale`; `stagnation` is the round-off floor of the corrections; `max_iterations`,
    !! `max_growth`, `contraction_limit`, `jacobian_cost`, `pivot_tolerance` act as in
    !! `newton_solve`. On success x is the solution and `state%delta` the last correction
    !! applied to it. Codes: HOLOSYM_SINGULAR_MATRIX (`state%singular_x`),
    !! HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED (also an iterate or residual
    !! beyond the range of real64), or a code of the system's evaluations; x is then the
    !! last iterate. `retry`: this solve retries a failed one (with factors the caller
    !! dropped): it does not count as a solve in the habit of preferring fresh factors, and
    !! uses the Newton matrix. `approximate`: start with the system's approximate matrix
    !! (see the module's description; default: no).
    subroutine kept_newton_solve(system, x, state, settings, scale, stagnation, report, &
                                 status, retry, approximate)
        class(nonlinear_system), intent(inout) :: system !! the equations
        real(wp), intent(inout) :: x(:)                 !! first guess in, solution out
        type(kept_newton_t), intent(inout) :: state     !! kept factors and workspace
        type(newton_settings_t), intent(in) :: settings !! Newton's settings
        real(wp), intent(in) :: scale       !! size of the state (> 0)
        real(wp), intent(in) :: stagnation  !! round-off floor of the corrections (relative)
        type(kept_report_t), intent(inout) :: report    !! work, added to
        type(holosym_status_t), intent(out) :: status   !! outcome
        logical, intent(in), optional :: retry          !! a retry (default: no)
        logical, intent(in), optional :: approximate    !! approximate matrix first
        type(solve_t) :: run
        logical :: first_try
        run%settings = settings
        run%scale = scale
        run%stagnation = stagnation
        first_try = .true.
        if (present(retry)) first_try = .not. retry
        if (first_try) state%have_singular_x = .false.
        if (state%prefer_fresh .and. first_try) then
            state%fresh_streak = state%fresh_streak + 1
            if (mod(state%fresh_streak, retry_kept_every) /= 0) state%factors%factored = .false.
        end if
        run%approximate = .false.
        if (present(approximate)) run%approximate = approximate .and. first_try
        if (run%approximate .and. state%prefer_newton) then
            state%newton_streak = state%newton_streak + 1
            run%approximate = mod(state%newton_streak, retry_approximate_every) == 0
        end if
        call iterate(system, x, state, run, report, status)
    end subroutine kept_newton_solve

    !> Simplified Newton from x: evaluate, correct, decide (`decide`), act; the real64
    !! phase first (real128 build), then the working-precision phase.
    subroutine iterate(system, x, state, run, report, status)
        class(nonlinear_system), intent(inout) :: system
        real(wp), intent(inout) :: x(:)
        type(kept_newton_t), intent(inout) :: state
        type(solve_t), intent(inout) :: run
        type(kept_report_t), intent(inout) :: report
        type(holosym_status_t), intent(out) :: status
        type(progress_t) :: pr
        real(wp) :: correction
        integer :: iter, action
        logical :: kept, need_factors

        pr%lowered = .not. wp_is_double
        pr%limit = contraction_limit_of(run%settings, banded_contraction_limit)
        pr%approximate_limit = contraction_limit_of(run%settings, approximate_contraction_limit)
        kept = state%factors%factored .and. .not. run%approximate
        need_factors = run%approximate .or. .not. state%factors%factored
        run%renewed = .false.
        run%watch = .false.
        run%first = 0
        run%low_rate = 1
        do iter = 1, run%settings%max_iterations
            report%iterations = report%iterations + 1
            ! The residual at x; new factors, when due, from the same evaluation.
            call evaluate(system, x, state, pr%lowered, report%iterations, status)
            if (.not. status%ok()) return
            if (need_factors) then
                call refactor(system, x, state, run, pr%lowered, report, status)
                if (.not. status%ok()) return
                call restart(pr)
                need_factors = .false.
            end if
            call phase_target(run, pr)
            correction = newton_correction(system, state, run)
            if (run%approximate) report%approximate = report%approximate + 1
            call decide(run, pr, correction, action)
            if (run%watch) call first_corrections(state, run, correction, action)
            if (action == ACTION_REFACTOR) then
                ! Poor contraction: fresh factors at x, same residual.
                call before_renewal(state, run, pr, kept)
                call refactor(system, x, state, run, pr%lowered, report, status)
                if (.not. status%ok()) return
                call restart(pr)
                correction = newton_correction(system, state, run)
                call decide(run, pr, correction, action)
            end if
            select case (action)
            case (ACTION_DIVERGED)
                call set_status(status, HOLOSYM_NEWTON_DIVERGED, "Newton corrections " // &
                    "grew " // int_str(pr%growth) // " times in a row (last " // &
                    real_str(correction) // ") at iteration " // int_str(iter))
                return
            case (ACTION_CONVERGED)
                x = x - real(state%delta, wp)
                if (run%approximate) state%prefer_newton = .false.
                if (.not. pr%lowered .or. run%settings%tolerance >= banded_phase_tolerance) then
                    state%ended_lowered = pr%lowered
                    state%ended_approximate = run%approximate
                    return
                end if
                need_factors = leave_real64_phase(run, pr, correction)
                cycle
            end select
            x = x - real(state%delta, wp)
            call advance(pr, correction)
        end do
        call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "Newton not converged " // &
            "after " // int_str(run%settings%max_iterations) // " iterations")
    end subroutine iterate

    !> Factors were formed at the current iterate: the history of the corrections starts
    !! again.
    pure subroutine restart(pr)
        type(progress_t), intent(inout) :: pr
        pr%fresh = .true.
        pr%previous = huge(1.0_wp)
        pr%last_rate = 0
    end subroutine restart

    !> The phase's tolerance and round-off floor: the real64 phase's, or the request's
    !! (looser by `approximate_tolerance_factor` for the approximate matrix).
    pure subroutine phase_target(run, pr)
        type(solve_t), intent(in) :: run
        type(progress_t), intent(inout) :: pr
        pr%target = run%settings%tolerance
        pr%floor = run%stagnation
        if (run%approximate) pr%target = pr%target * approximate_tolerance_factor
        if (pr%lowered) then
            pr%target = banded_phase_tolerance
            pr%floor = banded_phase_floor
        end if
    end subroutine phase_target

    !> What to do after `correction`: the policy's decision (`next_action`) for the Newton
    !! matrix, `approximate_action` for the approximate one.
    pure subroutine decide(run, pr, correction, action)
        type(solve_t), intent(in) :: run
        type(progress_t), intent(inout) :: pr
        real(wp), intent(in) :: correction
        integer, intent(out) :: action
        if (run%approximate) then
            call approximate_action(correction, pr%previous, pr%last_rate, pr%target, &
                                    pr%floor, run%settings%max_growth, pr%approximate_limit, &
                                    pr%growth, action)
        else
            call next_action(correction, pr%previous, pr%last_rate, pr%target, pr%floor, &
                             pr%fresh, run%settings%max_growth, pr%limit, pr%growth, action)
        end if
    end subroutine decide

    !> Before new factors for a poor contraction: kept factors are formed fresh at each
    !! solve from now on; the approximate matrix is formed again at x once (the first
    !! guess may be far, e.g. the constant one), then gives way to the Newton matrix.
    pure subroutine before_renewal(state, run, pr, kept)
        type(kept_newton_t), intent(inout) :: state
        type(solve_t), intent(inout) :: run
        type(progress_t), intent(inout) :: pr
        logical, intent(in) :: kept !! the solve began with kept factors
        if (kept) state%prefer_fresh = .true.
        if (.not. run%approximate) return
        if (run%approximate_renewed) then
            state%prefer_newton = .true.
            run%approximate = .false.
            pr%growth = 0
        end if
        run%approximate_renewed = .true.
    end subroutine before_renewal

    !> The real64 phase has converged: the working-precision phase follows, with fresh
    !! factors when `end_real64_phase` says they pay (true: form them) and the history of
    !! the corrections begun again.
    logical function leave_real64_phase(run, pr, correction) result(need_factors)
        type(solve_t), intent(inout) :: run
        type(progress_t), intent(inout) :: pr
        real(wp), intent(in) :: correction !! the real64 phase's last correction
        real(wp) :: rate
        pr%lowered = .false.
        rate = 1
        if (pr%previous < huge(1.0_wp)) rate = correction / pr%previous
        need_factors = end_real64_phase(run, rate, correction, pr%previous)
        if (need_factors) run%approximate = .false.
        pr%previous = huge(1.0_wp)
        pr%last_rate = 0
    end function leave_real64_phase

    !> A correction applied that did not end the phase: the history moves on; factors
    !! formed at an earlier iterate are no longer fresh (a poor rate then calls for new
    !! ones at the current iterate: full Newton).
    pure subroutine advance(pr, correction)
        type(progress_t), intent(inout) :: pr
        real(wp), intent(in) :: correction
        if (pr%previous < huge(1.0_wp)) pr%last_rate = correction / pr%previous
        pr%previous = correction
        pr%fresh = .false.
    end subroutine advance

    !> The residual at x, in real64 (`lowered`) or working precision, into f_low (and f).
    !! An iterate or residual beyond the range of real64 (h far beyond the system's scale)
    !! cannot be lowered: the iteration has diverged.
    subroutine evaluate(system, x, state, lowered, iteration, status)
        class(nonlinear_system), intent(inout) :: system
        real(wp), intent(in) :: x(:)
        type(kept_newton_t), intent(inout) :: state
        logical, intent(in) :: lowered
        integer, intent(in) :: iteration
        type(holosym_status_t), intent(out) :: status
        if (lowered) then
            if (.not. fits_real64(x)) then
                call beyond_real64("iterate", iteration, status)
                return
            end if
            state%x_low = real(x, dp)
            call system%residual_dp(state%x_low, state%f_low, status)
        else
            call system%residual(x, state%f, status)
            if (.not. status%ok()) return
            if (.not. fits_real64(state%f)) then
                call beyond_real64("residual", iteration, status)
                return
            end if
            state%f_low = real(state%f, dp)
        end if
    end subroutine evaluate

    !> At the end of the real64 phase (last correction `correction`, contraction `rate`,
    !! the one before `previous`): whether to renew the factors for the working-precision
    !! phase (`renewal_pays`), and the known contraction of the kept ones (a rate measured
    !! above the real64 round-off predicts theirs) for `first_corrections`.
    logical function end_real64_phase(run, rate, correction, previous) result(renew)
        type(solve_t), intent(inout) :: run
        real(wp), intent(in) :: rate, correction, previous
        renew = renewal_pays(rate, correction, run%settings%tolerance, &
                             jacobian_cost_of(run%settings, banded_jacobian_cost))
        run%renewed = renew
        run%low_rate = 1
        if (previous < huge(1.0_wp) .and. correction > 10 * banded_phase_tolerance &
            .and. rate < 1) run%low_rate = rate
        run%watch = .true.
    end function end_real64_phase

    !> HOLOSYM_NEWTON_DIVERGED: the `what` of the iteration left the range of real64.
    subroutine beyond_real64(what, iteration, status)
        character(len=*), intent(in) :: what
        integer, intent(in) :: iteration
        type(holosym_status_t), intent(out) :: status
        call set_status(status, HOLOSYM_NEWTON_DIVERGED, "Newton diverged: the " // &
            what // " left the range of real64 at iteration " // int_str(iteration))
    end subroutine beyond_real64

    !> The first working-precision corrections: the first is accepted when a known
    !! contraction predicts the tolerance met: that of the real64 phase when its factors
    !! are kept, or `learned_rate` for factors renewed at its end (the second correction
    !! after a renewal measures it again; every `remeasure_every`-th solve does so). The
    !! approximate matrix's corrections meet `approximate_tolerance_factor` of it.
    subroutine first_corrections(state, run, correction, action)
        type(kept_newton_t), intent(inout) :: state
        type(solve_t), intent(inout) :: run
        real(wp), intent(in) :: correction
        integer, intent(inout) :: action
        real(wp) :: known, tolerance
        tolerance = run%settings%tolerance
        if (run%approximate) tolerance = tolerance * approximate_tolerance_factor
        if (run%first == 0) then
            run%first = correction
            if (run%renewed) then
                state%steps_since_measured = state%steps_since_measured + 1
                known = state%learned_rate
                if (state%steps_since_measured >= remeasure_every) known = 1
            else
                known = run%low_rate
            end if
            if (action == ACTION_ITERATE .and. predicted_within(known, correction, &
                    tolerance, rate_margin)) action = ACTION_CONVERGED
        else if (run%renewed) then
            if (run%first > 0) state%learned_rate = correction / run%first
            state%steps_since_measured = 0
            run%renewed = .false.
        end if
        if (run%first /= correction) run%watch = run%renewed
    end subroutine first_corrections

    !> delta = the correction for the residual f_low (of the Newton factors, or of the
    !! system's approximate matrix); its size relative to the state (`run%scale`).
    real(wp) function newton_correction(system, state, run) result(correction)
        class(nonlinear_system), intent(inout) :: system
        type(kept_newton_t), intent(inout) :: state
        type(solve_t), intent(in) :: run
        state%delta = state%f_low
        if (run%approximate) then
            call system%solve_approximate(state%delta)
        else
            call state%factors%solve(state%delta)
        end if
        correction = maxval(abs(state%delta)) / run%scale
    end function newton_correction

    !> What to do after a correction of the approximate matrix: as `next_action` for
    !! factors formed in this solve, except that a contraction weaker than `limit`
    !! (`approximate_contraction_limit`, or the settings' `contraction_limit` when given)
    !! or a non-finite correction above the round-off floor calls for the Newton matrix
    !! (REFACTOR) instead of more iterations.
    pure subroutine approximate_action(correction, previous, last_rate, target, floor, &
                                       max_growth, limit, growth, action)
        real(wp), intent(in) :: correction, previous, last_rate, target, floor, limit
        integer, intent(in) :: max_growth
        integer, intent(inout) :: growth
        integer, intent(out) :: action
        call next_action(correction, previous, last_rate, target, floor, .true., &
                         max_growth, 1.0_wp, growth, action)
        if (action == ACTION_CONVERGED) return
        if (.not. ieee_is_finite(correction)) then
            action = ACTION_REFACTOR
        else if (previous < huge(1.0_wp) .and. correction > floor) then
            if (correction > limit * previous) action = ACTION_REFACTOR
        end if
    end subroutine approximate_action

    !> Form and factor the Newton matrix at x from the evaluation just made there (real64
    !! or working precision), or the approximate matrix in approximate mode (leaving that
    !! mode when the system has none or it is singular).
    subroutine refactor(system, x, state, run, lowered, report, status)
        class(nonlinear_system), intent(inout) :: system
        real(wp), intent(in) :: x(:)
        type(kept_newton_t), intent(inout) :: state
        type(solve_t), intent(inout) :: run
        logical, intent(in) :: lowered
        type(kept_report_t), intent(inout) :: report
        type(holosym_status_t), intent(out) :: status
        integer :: info
        if (run%approximate) then
            call system%factor_approximate(x, lowered, info, status)
            if (.not. status%ok()) return
            if (info == 0) return
            ! None, or singular (dependent constraints): the Newton matrix says which.
            run%approximate = .false.
        end if
        call system%factor_matrix(x, lowered, state%factors, &
                                  real(run%settings%pivot_tolerance, dp), info, status)
        if (.not. status%ok()) return
        report%factorizations = report%factorizations + 1
        if (info /= 0) then
            state%singular_x = x
            state%have_singular_x = .true.
            call set_status(status, HOLOSYM_SINGULAR_MATRIX, "Newton matrix singular at " // &
                "pivot " // int_str(info) // " of " // int_str(size(x)))
        end if
    end subroutine refactor

end module holosym_kept_newton
