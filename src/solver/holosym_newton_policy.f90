!> category: internal module (use holosym)
!! The Newton policy: every decision of a Newton iteration (converged? stagnated?
!! diverging? refactor? when does the real64 phase end?) as a small pure function of the
!! sizes of the corrections, with every constant it uses named here beside its reason.
!! Both Newton iterations of the library take their decisions here: `newton_solve`
!! (dense factors, working precision or real64) and `kept_newton_solve` (real64 factors,
!! dense or banded, kept across solves; the reduced step's iteration). The decisions know
!! no scheme: only corrections (sizes relative to the state), their ratios (contraction
!! rates), targets and the kind of factors.
module holosym_newton_policy
    ! The intrinsic classification: pure, and inlined in the decisions of every iteration.
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use holosym_kinds, only: wp, dp
    implicit none
    private

    public :: corrections_needed, predicted_within, stagnated, growth_after, &
        refactor_pays, renewal_pays, slow_iterations, kept_factors_stale, next_action

    !> What `next_action` decides after a correction of the kept-factor iteration.
    integer, parameter, public :: ACTION_ITERATE = 0, ACTION_CONVERGED = 1, &
        ACTION_REFACTOR = 2, ACTION_DIVERGED = 3

    !> Safety factor on the error predicted from a linear contraction rate (simplified
    !! Newton, real64 factors), which varies from one iteration to the next.
    real(wp), parameter, public :: rate_margin = 8
    !> After kept factors proved too stale, solves refactor at their first iterate; every
    !! this many solves the kept factors are tried again.
    integer, parameter, public :: retry_kept_every = 8

    !> Dense factors that contract worse than this per iteration are replaced (the
    !! default `contraction_limit` of `newton_solve`: a dense factorisation costs O(n^3),
    !! so the limit is strict) ...
    real(wp), parameter, public :: dense_contraction_limit = 0.05_wp
    !> ... and banded or small real64 factors (the reduced step's) beyond this one: they
    !! are cheap to renew, but each renewal also costs a real64 Newton matrix.
    real(wp), parameter, public :: banded_contraction_limit = 0.1_wp
    !> The iteration without the Newton matrix (an approximate matrix the system offers,
    !! `factor_approximate`) is kept while it contracts by this much per iteration, and
    !! replaced by the Newton matrix beyond: at 0.1 per iteration six digits take six
    !! cheap corrections, about what forming and factoring a Newton matrix and two
    !! corrections with it cost in real64 (the matrix costs several residuals there).
    real(wp), parameter, public :: approximate_contraction_limit = 0.1_wp
    !> A solve that ends with corrections of the approximate matrix meets this fraction of
    !! the tolerance: the step's results are updated across the last correction without
    !! the curvature terms, an error of (rate x correction) with the same sign step after
    !! step, which makes conserved quantities drift (the spherical pendulum's L_z by
    !! 0.5 eps sqrt(k) at 8 eps, against 0.04 for the Newton matrix, whose first-order
    !! update is exact) unless it lies well below the round-off of a step.
    real(wp), parameter, public :: approximate_tolerance_factor = 1.0_wp / 64
    !> After the approximate matrix proved too weak, solves use the Newton matrix; every
    !! this many solves the approximate one is tried again.
    integer, parameter, public :: retry_approximate_every = 32
    !> Forming and factoring a dense Newton matrix costs about two working-precision
    !! residuals on the example systems (the default `jacobian_cost` of `newton_solve`) ...
    real(wp), parameter, public :: dense_jacobian_cost = 2
    !> ... and the reduced step's real64 matrix about one.
    real(wp), parameter, public :: banded_jacobian_cost = 1
    !> Cost of a lowered (real64) residual relative to a working-precision one (roughly, on
    !! the example systems), for the refactoring decision during a real64 phase.
    real(wp), parameter, public :: lowered_cost_ratio = 0.25_wp

    !> The pre-solve of `newton_solve` (dense factors, `settings%presolve`) stops when its
    !! corrections reach this size, about 1.6e-10: well above the real64 round-off of the
    !! lowered residual (cond * 1e-16, where its iterations stagnate and refactor in vain),
    !! and close enough that real64 factors taken there finish in two working-precision
    !! residuals (error e -> kappa e^2 + 1e-16 e); stopping nearer the real64 round-off
    !! costs more iterations, stopping earlier gains nothing. (eps**(5/8) written with
    !! square roots, which every compiler folds in real128.)
    real(wp), parameter, public :: presolve_tolerance = sqrt(real(epsilon(1.0_dp), wp)) * &
        sqrt(sqrt(sqrt(real(epsilon(1.0_dp), wp))))
    !> ... or stop decreasing below this one (real64 round-off of the lowered residual).
    real(wp), parameter, public :: presolve_floor = sqrt(real(epsilon(1.0_dp), wp))
    !> The reduced step's real64 phase goes on to corrections of this size (about 450
    !! real64 epsilons: above its round-off, where it would stagnate): its equations are
    !! better conditioned (momenta eliminated, rows equilibrated), and a real64 phase that
    !! ends here leaves one or two working-precision corrections ...
    real(wp), parameter, public :: banded_phase_tolerance = 1.0e-13_wp
    !> ... or stops when they stop decreasing below this one.
    real(wp), parameter, public :: banded_phase_floor = 1.0e-10_wp
    !> A freshly factorised real64 Jacobian of `newton_solve` that contracts worse than
    !! this is replaced by a working-precision factorisation (too ill-conditioned for
    !! real64) ...
    real(wp), parameter, public :: mixed_rate_limit = 0.5_wp
    !> ... judged from this iteration on (earlier rates may reflect a far first guess).
    integer, parameter, public :: mixed_rate_iteration = 3
    !> The contraction that renewed real64 factors achieve at the end of the reduced
    !! step's real64 phase (their error is then real64 round-off), for `renewal_pays`.
    real(wp), parameter, public :: renewed_rate = 1.0e-12_wp
    !> Factors renewed at the end of the real64 phase have their contraction measured again
    !! after this many solves that trusted the last measurement (the matrix drifts with the
    !! state; one extra correction every 16 solves is cheap).
    integer, parameter, public :: remeasure_every = 16
    !> Kept factors that would need more than this many further corrections are replaced
    !! (Newton with new factors converges quadratically).
    real(dp), parameter, public :: slow_limit = 4
    !> Corrections within this factor of the target are finished with the factors at hand
    !! (their rates are dominated by round-off there, and a few more solves cost less than
    !! new factors).
    real(wp), parameter, public :: refactor_floor = 64
    !> Below the round-off floor, corrections shrinking by less than this factor (the
    !! reduced step) have stagnated; `newton_solve` asks for no decrease at all (1).
    real(wp), parameter, public :: stagnation_rate = 0.5_wp

contains

    !> How many corrections contracting by `rate` (0 < rate < 1) take an error `error` down
    !! to `target`, as a real number: log(target / error) / log(rate). In real64
    !! arithmetic (working-precision logarithms are slow in real128).
    pure real(dp) function corrections_needed(rate, error, target) result(count)
        real(wp), intent(in) :: rate   !! contraction per correction
        real(wp), intent(in) :: error  !! the error now
        real(wp), intent(in) :: target !! the error wanted
        count = log(real(target / error, dp)) / log(real(rate, dp))
    end function corrections_needed

    !> Whether the error left after a correction of size `correction`, predicted from the
    !! contraction `rate` as rate / (1 - rate) correction, is within `target / margin`
    !! (`margin` 1 for full Newton, `rate_margin` for linear contraction; powers of two).
    !! False when the corrections do not contract (rate >= 1).
    pure logical function predicted_within(rate, correction, target, margin) result(within)
        real(wp), intent(in) :: rate, correction, target, margin
        within = .false.
        if (rate >= 1) return
        ! Scaling by the margin, a power of two, is exact on either side: multiplying
        ! the error by it costs no division.
        within = rate / (1 - rate) * correction * margin <= target
    end function predicted_within

    !> Whether a correction of size `correction` at or below the round-off `floor` that
    !! shrank by no more than `least` (rate = correction / previous >= least) is round-off
    !! noise: the iteration can do no better.
    pure logical function stagnated(rate, correction, floor, least)
        real(wp), intent(in) :: rate, correction, floor, least
        stagnated = correction <= floor .and. rate >= least
    end function stagnated

    !> The count of consecutive growing corrections after one with contraction `rate`:
    !! `growth` + 1 when it grew (rate > 1, or >= 1 when `equal_grows`), else 0. A solve
    !! has diverged when the count reaches `max_growth`.
    pure integer function growth_after(rate, growth, equal_grows) result(next)
        real(wp), intent(in) :: rate
        integer, intent(in) :: growth
        logical, intent(in) :: equal_grows
        next = 0
        if (rate > 1 .or. (equal_grows .and. rate >= 1)) next = growth + 1
    end function growth_after

    !> Whether simplified Newton should refactor at the current iterate (`newton_solve`).
    !! With factors contracting by `rate`, the error left after a correction of size
    !! `correction` is e = rate/(1-rate) correction and reaching `tolerance` takes
    !! `corrections_needed(rate, e, tolerance)` more residuals; fresh factors at this
    !! iterate would contract by about max(kappa e, rate_floor) for the price of
    !! `jacobian_cost` residuals.
    pure logical function refactor_pays(rate, correction, kappa, rate_floor, tolerance, &
                                        jacobian_cost)
        real(wp), intent(in) :: rate          !! contraction of the kept factors, > 0
        real(wp), intent(in) :: correction    !! size of the last correction
        real(wp), intent(in) :: kappa         !! quadratic-convergence constant (0: unknown)
        real(wp), intent(in) :: rate_floor    !! best contraction the linear solver allows
        real(wp), intent(in) :: tolerance     !! convergence tolerance on the correction
        real(wp), intent(in) :: jacobian_cost !! Jacobian + factorisation, in residuals
        real(wp) :: remaining, fresh_rate
        real(dp) :: reach
        refactor_pays = .false.
        if (kappa <= 0 .or. rate <= 0 .or. rate >= 1) return
        remaining = rate / (1 - rate) * correction
        if (remaining <= tolerance) return
        fresh_rate = max(kappa * remaining, rate_floor)
        if (fresh_rate >= rate) return
        ! corrections_needed for both rates, sharing the logarithm of the reach.
        reach = log(real(tolerance / remaining, dp))
        refactor_pays = jacobian_cost + reach / log(real(fresh_rate, dp)) < &
            reach / log(real(rate, dp))
    end function refactor_pays

    !> At the end of the reduced step's real64 phase (last correction `correction`,
    !! contraction `rate`): whether factors renewed there (contracting by `renewed_rate`)
    !! reach `tolerance` in fewer whole working-precision residuals than the kept ones,
    !! counting `jacobian_cost` residuals for renewing them.
    pure logical function renewal_pays(rate, correction, tolerance, jacobian_cost)
        real(wp), intent(in) :: rate, correction, tolerance, jacobian_cost
        real(dp) :: reach
        renewal_pays = .false.
        if (correction <= tolerance .or. rate <= renewed_rate) return
        if (rate >= 1) then
            renewal_pays = .true.
            return
        end if
        ! corrections_needed for both rates, sharing the logarithm of the reach.
        reach = log(real(tolerance / correction, dp))
        renewal_pays = ceiling(reach / log(real(renewed_rate, dp))) + jacobian_cost < &
            ceiling(reach / log(real(rate, dp)))
    end function renewal_pays

    !> True when factors contracting by `rate` would need more than `slow_limit` further
    !! corrections from `correction` down to `target`: new factors cost less then.
    pure logical function slow_iterations(rate, correction, target)
        real(wp), intent(in) :: rate, correction, target
        slow_iterations = .false.
        if (rate <= 0 .or. rate >= 1 .or. correction <= target) return
        slow_iterations = corrections_needed(rate, correction, target) > slow_limit
    end function slow_iterations

    !> Whether factors formed at an earlier iterate should be replaced after a correction
    !! `correction` contracting by `rate` towards `target` (the reduced step): far from the
    !! target (more than `refactor_floor` times it) and contracting worse than `limit` or
    !! too slowly to reach it soon.
    pure logical function kept_factors_stale(rate, correction, target, limit) result(stale)
        real(wp), intent(in) :: rate, correction, target, limit
        stale = .false.
        if (correction <= refactor_floor * target) return
        stale = rate > limit
        if (.not. stale) stale = slow_iterations(rate, correction, target)
    end function kept_factors_stale


    !> What to do after a Newton correction of relative size `correction` (`previous`: the
    !! one before with the same factors, huge when none; `last_rate`: the contraction
    !! before that, 0 when none):
    !! - CONVERGED when the correction, or the error predicted from the contraction rate
    !!   theta, theta / (1 - theta) correction with theta the larger of the last two rates
    !!   (with the margin `rate_margin`), is within `target`; or when corrections stop
    !!   decreasing (by `stagnation_rate`) below `floor` (round-off);
    !! - REFACTOR, far from the target, when factors formed at an earlier iterate contract
    !!   worse than `limit` or too slowly to reach it soon
    !!   (`slow_iterations`);
    !! - DIVERGED after `max_growth` growing corrections with fresh factors;
    !! - else ITERATE.
    pure subroutine next_action(correction, previous, last_rate, target, floor, fresh, &
                                max_growth, limit, growth, action)
        real(wp), intent(in) :: correction, previous, last_rate, target, floor
        logical, intent(in) :: fresh   !! the factors were formed in this solve
        integer, intent(in) :: max_growth !! growing corrections that mean divergence
        real(wp), intent(in) :: limit  !! the contraction limit of kept factors
        integer, intent(inout) :: growth !! growing corrections so far
        integer, intent(out) :: action   !! ACTION_ITERATE, _CONVERGED, _REFACTOR, _DIVERGED
        real(wp) :: rate
        action = ACTION_ITERATE
        if (.not. ieee_is_finite(correction)) then
            growth = max_growth
            action = ACTION_DIVERGED
            return
        end if
        if (correction <= target) then
            action = ACTION_CONVERGED
            return
        end if
        if (previous == huge(1.0_wp)) return
        rate = correction / previous
        if (predicted_within(max(rate, last_rate), correction, target, rate_margin)) then
            action = ACTION_CONVERGED
            return
        end if
        if (correction <= floor) then
            ! Round-off: corrections this small that no longer decrease are noise of the
            ! residual, not a sign of stale factors.
            if (stagnated(rate, correction, floor, stagnation_rate)) action = ACTION_CONVERGED
            return
        end if
        if (.not. fresh) then
            if (kept_factors_stale(rate, correction, target, limit)) then
                action = ACTION_REFACTOR
                return
            end if
        end if
        growth = growth_after(rate, growth, .true.)
        if (growth >= max_growth) action = ACTION_DIVERGED
    end subroutine next_action

end module holosym_newton_policy
