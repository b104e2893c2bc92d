!> category: internal module (use holosym)
!! One step of the reduced scheme (`holosym_reduced_scheme`) by simplified Newton with
!! mixed precision: a real64 Newton matrix (differences of the real64 residual; dense or
!! banded LU, `holosym_factors`) kept across iterations and steps while it contracts well;
!! first iterations on the real64 residual, then on the working-precision residual to the
!! requested tolerance. The last correction is applied without a confirming residual when
!! the contraction rate says the result is within the tolerance: the step results are
!! then updated to first order through the difference matrix of p_b - p_a.
module holosym_reduced_step
    ! The intrinsic classification (inlined; at module level it adds no per-call
    ! floating-point state handling) for the checks inside every iteration.
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use holosym_kinds, only: wp, dp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, &
        HOLOSYM_NEWTON_DIVERGED, is_system_fault
    use holosym_problem, only: constrained_hamiltonian
    use holosym_reduced_scheme, only: reduced_scheme_t
    use holosym_factors, only: real64_factors_t
    use holosym_newton, only: newton_settings_t, contraction_limit_of, jacobian_cost_of
    use holosym_newton_policy, only: predicted_within, stagnated, growth_after, renewal_pays, &
        kept_factors_stale, rate_margin, retry_kept_every, banded_contraction_limit, &
        banded_jacobian_cost, banded_phase_tolerance, banded_phase_floor, stagnation_rate
    implicit none
    private

    public :: reduced_step_t, reduced_report_t

    !> Outcomes of one Newton iteration (see `next_action`).
    integer, parameter :: ACTION_ITERATE = 0, ACTION_CONVERGED = 1, ACTION_REFACTOR = 2, &
        ACTION_DIVERGED = 3

    !> What one solve carries between its iterations and the procedures they call.
    type :: solve_t
        type(newton_settings_t) :: settings !! Newton's settings
        real(wp) :: scale = 1       !! size of the state (corrections are relative to it)
        real(wp) :: h = 0           !! the step size
        real(wp) :: stagnation = 0  !! round-off floor of the working-precision corrections
        !> First working-precision correction after the real64 phase (0: none yet), and
        !! whether the first corrections are being watched (`first_corrections`).
        real(wp) :: first = 0
        logical :: watch = .false.
        !> Factors were renewed at the end of the real64 phase.
        logical :: renewed = .false.
        !> Contraction of the kept factors measured in the real64 phase (1: none).
        real(wp) :: low_rate = 1
    end type solve_t

    !> Work of one step.
    type :: reduced_report_t
        integer :: iterations = 0            !! Newton iterations (residuals solved with)
        integer :: residuals = 0             !! working-precision residuals
        integer :: lowered_residuals = 0     !! real64 residuals (including the Jacobians')
        integer :: factorizations = 0        !! Newton matrices formed and factored
        real(wp) :: pivot_ratio = 0          !! of the factors in use
    end type reduced_report_t

    !> The reduced step with its kept factors and the previous step (for extrapolation).
    type :: reduced_step_t
        type(reduced_scheme_t) :: scheme
        type(real64_factors_t) :: factors
        real(wp) :: factors_h = 0
        !> Kept factors proved too stale: form fresh ones at each step's first guess (tried
        !! again every `retry_kept_every` steps).
        logical :: prefer_fresh = .false.
        integer :: fresh_streak = 0
        !> Contraction of factors formed at the end of the real64 phase, as measured by the
        !! working-precision corrections (1: not measured yet). Lets a step accept its first
        !! working-precision correction when that is predicted to meet the tolerance.
        real(wp) :: learned_rate = 1
        integer :: steps_since_measured = 0
        real(wp), allocatable :: x(:), f(:), x_guess(:)
        real(dp), allocatable :: x_low(:), delta(:), f_low(:)
        !> The last solve started from the extrapolated guess (else from the constant one).
        logical :: extrapolated = .false.
        !> The iterate at which the Newton matrix was last found singular during the last
        !! solve (valid when `have_singular_x`): where the constraints may be dependent.
        logical :: have_singular_x = .false.
        real(wp), allocatable :: singular_x(:)
        ! The previous accepted step (see `accept`).
        logical :: have_last = .false.
        real(wp), allocatable :: last_x(:), last_qa(:)
        real(wp) :: last_h = 0
    contains
        procedure :: init => step_init
        procedure :: solve => step_solve
        procedure :: accept => step_accept
        procedure :: forget => step_forget
    end type reduced_step_t

contains

    !> Set up for a system and (M, N, G); codes of `reduced_scheme_t%init`.
    subroutine step_init(self, sys, order_m, order_n, gauss_points, status)
        class(reduced_step_t), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        integer, intent(in) :: order_m, order_n, gauss_points
        type(holosym_status_t), intent(out) :: status
        integer :: nx
        call self%scheme%init(sys, order_m, order_n, gauss_points, status)
        if (.not. status%ok()) return
        nx = self%scheme%nx
        call self%factors%setup(nx, self%scheme%layout%kl, self%scheme%layout%ku)
        if (allocated(self%x)) deallocate (self%x, self%f, self%x_guess, self%x_low, &
                                           self%delta, self%f_low, self%last_x, self%last_qa, &
                                           self%singular_x)
        allocate (self%x(nx), self%f(nx), self%x_guess(nx), self%x_low(nx), self%delta(nx), &
                  self%f_low(nx), self%last_x(nx), self%last_qa(sys%n), self%singular_x(nx))
        call self%forget()
    end subroutine step_init

    !> Forget the kept factors, what earlier steps taught about them and the previous step:
    !! the next steps then depend only on their own inputs.
    subroutine step_forget(self)
        class(reduced_step_t), intent(inout) :: self
        self%factors%factored = .false.
        self%factors_h = 0
        self%prefer_fresh = .false.
        self%fresh_streak = 0
        self%learned_rate = 1
        self%steps_since_measured = 0
        self%have_last = .false.
    end subroutine step_forget

    !> Solve the step from (q, p) with size h: increments dq = q_b - q_a, dpb = p_b - p_a,
    !! and the solution in `x`; `accept` makes it the previous step of the next solve.
    !! `settings` (the integrator's `newton`): `tolerance` bounds the Newton error relative
    !! to the state's size (`scale`), `stagnation` is the round-off floor of the
    !! corrections, and `max_iterations`, `max_growth`, `contraction_limit`,
    !! `jacobian_cost`, `pivot_tolerance` act as in `newton_solve`;
    !! `continues` starts from the previous accepted step's polynomials (when its h is the
    !! same). On failure the kept factors and the previous step are dropped. Codes:
    !! HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED (also
    !! equations that overflow), HOLOSYM_NONFINITE_VALUE (from the system's procedures).
    subroutine step_solve(self, sys, q, p, h, settings, stagnation, continues, dq, dpb, &
                          report, status)
        class(reduced_step_t), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(newton_settings_t), intent(in) :: settings !! Newton's settings
        real(wp), intent(in) :: stagnation  !! round-off floor of the corrections (relative)
        logical, intent(in) :: continues    !! (q, p) is the previous step's end: extrapolate
        real(wp), intent(out) :: dq(:), dpb(:)
        type(reduced_report_t), intent(out) :: report
        type(holosym_status_t), intent(out) :: status
        type(solve_t) :: run
        integer :: residuals0, lowered0

        residuals0 = self%scheme%residuals
        lowered0 = self%scheme%lowered_residuals
        call self%scheme%set_step(sys, q, p, h, status)
        if (.not. status%ok()) return
        run%settings = settings
        run%h = h
        run%stagnation = stagnation
        run%scale = max(maxval(abs(q)), maxval(abs(p)))
        if (run%scale <= 0) run%scale = 1
        if (h /= self%factors_h) self%factors%factored = .false.
        if (self%prefer_fresh) then
            self%fresh_streak = self%fresh_streak + 1
            if (mod(self%fresh_streak, retry_kept_every) /= 0) self%factors%factored = .false.
        end if
        self%have_singular_x = .false.
        self%extrapolated = continues .and. self%have_last .and. h == self%last_h
        if (self%extrapolated) then
            call self%scheme%extrapolated_guess(self%last_x, self%last_qa, q, self%x_guess)
        else
            self%x_guess = 0
        end if
        self%x = self%x_guess
        call iterate(self, run, dq, dpb, report, status)
        if (.not. status%ok() .and. .not. is_system_fault(status%code)) then
            ! Kept factors may be stale, or the extrapolation poor: fresh factors from the
            ! constant guess.
            self%factors%factored = .false.
            self%extrapolated = .false.
            self%x = 0
            call iterate(self, run, dq, dpb, report, status)
        end if
        report%residuals = self%scheme%residuals - residuals0
        report%lowered_residuals = self%scheme%lowered_residuals - lowered0
        report%pivot_ratio = real(self%factors%pivot_ratio, wp)
        if (.not. status%ok()) then
            self%factors%factored = .false.
            self%have_last = .false.
        end if
    end subroutine step_solve

    !> Simplified Newton from self%x (the decisions: `next_action`); on success x is the
    !! solution and dq, dpb the step's results.
    subroutine iterate(self, run, dq, dpb, report, status)
        class(reduced_step_t), intent(inout) :: self
        type(solve_t), intent(inout) :: run
        real(wp), intent(out) :: dq(:), dpb(:)
        type(reduced_report_t), intent(inout) :: report
        type(holosym_status_t), intent(out) :: status
        real(wp) :: correction, previous, target, floor, rate, last_rate
        integer :: iter, growth, action
        logical :: lowered, fresh, kept, need_factors

        lowered = .not. wp_is_double
        previous = huge(1.0_wp)
        growth = 0
        fresh = .false.
        rate = 1
        last_rate = 0
        kept = self%factors%factored
        need_factors = .not. self%factors%factored
        run%renewed = .false.
        run%watch = .false.
        run%first = 0
        run%low_rate = 1
        do iter = 1, run%settings%max_iterations
            report%iterations = report%iterations + 1
            ! The residual at x; new factors, when due, from the same evaluation.
            call evaluate(self, lowered, report%iterations, status)
            if (.not. status%ok()) return
            if (need_factors) then
                call refactor(self, run, lowered, report, status)
                if (.not. status%ok()) return
                fresh = .true.
                need_factors = .false.
                previous = huge(1.0_wp)
                last_rate = 0
            end if
            target = run%settings%tolerance
            floor = run%stagnation
            if (lowered) then
                target = banded_phase_tolerance
                floor = banded_phase_floor
            end if
            correction = newton_correction(self, run%scale)
            action = next_action(correction, previous, last_rate, target, floor, fresh, &
                                 run%settings, growth)
            if (run%watch) call first_corrections(self, run, correction, action)
            if (action == ACTION_REFACTOR) then
                ! Kept factors contract poorly: fresh ones at x, same residual.
                if (kept) self%prefer_fresh = .true.
                call refactor(self, run, lowered, report, status)
                if (.not. status%ok()) return
                fresh = .true.
                previous = huge(1.0_wp)
                last_rate = 0
                correction = newton_correction(self, run%scale)
                action = next_action(correction, previous, last_rate, target, floor, &
                                     fresh, run%settings, growth)
            end if
            select case (action)
            case (ACTION_DIVERGED)
                call set_status(status, HOLOSYM_NEWTON_DIVERGED, "Newton corrections " // &
                    "grew " // int_str(growth) // " times in a row (last " // &
                    real_str(correction) // ") at iteration " // int_str(iter))
                return
            case (ACTION_CONVERGED)
                self%x = self%x - real(self%delta, wp)
                if (.not. lowered .or. run%settings%tolerance >= banded_phase_tolerance) then
                    call finish(self, lowered, dq, dpb)
                    return
                end if
                ! The end of the real64 phase.
                lowered = .false.
                if (previous < huge(1.0_wp)) rate = correction / previous
                need_factors = end_real64_phase(run, rate, correction, previous)
                previous = huge(1.0_wp)
                last_rate = 0
                cycle
            end select
            self%x = self%x - real(self%delta, wp)
            if (previous < huge(1.0_wp)) last_rate = correction / previous
            previous = correction
            ! Factors formed at an earlier iterate are no longer fresh: a poor rate then
            ! calls for new ones at the current iterate (full Newton).
            fresh = .false.
        end do
        call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "Newton not converged " // &
            "after " // int_str(run%settings%max_iterations) // " iterations")
    end subroutine iterate

    !> The residual at self%x, in real64 (`lowered`) or working precision, into f_low (and
    !! f). An iterate or residual beyond the range of real64 (h far beyond the system's
    !! scale) cannot be lowered: the iteration has diverged.
    subroutine evaluate(self, lowered, iteration, status)
        class(reduced_step_t), intent(inout) :: self
        logical, intent(in) :: lowered
        integer, intent(in) :: iteration
        type(holosym_status_t), intent(out) :: status
        if (lowered) then
            if (.not. fits_real64(self%x)) then
                call beyond_real64("iterate", iteration, status)
                return
            end if
            self%x_low = real(self%x, dp)
            call self%scheme%residual_dp(self%x_low, self%f_low, status)
        else
            call self%scheme%residual(self%x, self%f, status)
            if (.not. status%ok()) return
            if (.not. fits_real64(self%f)) then
                call beyond_real64("residual", iteration, status)
                return
            end if
            self%f_low = real(self%f, dp)
        end if
    end subroutine evaluate

    !> The step's results, accepted without a confirming residual: from the evaluation at
    !! the last iterate, updated to first order across the last correction (a tolerance
    !! the real64 phase meets needs no working-precision residual at all).
    subroutine finish(self, lowered, dq, dpb)
        class(reduced_step_t), intent(inout) :: self
        logical, intent(in) :: lowered
        real(wp), intent(out) :: dq(:), dpb(:)
        call self%scheme%increments(dq, dpb, lowered)
        call self%scheme%linear_dp_change(-self%delta, self%f(1:size(dpb)))
        dq = self%x(self%scheme%layout%z_col(:, self%scheme%order_m))
        dpb = dpb + self%f(1:size(dpb))
    end subroutine finish

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
    !! after a renewal measures it again; every 16th step does so).
    subroutine first_corrections(self, run, correction, action)
        class(reduced_step_t), intent(inout) :: self
        type(solve_t), intent(inout) :: run
        real(wp), intent(in) :: correction
        integer, intent(inout) :: action
        real(wp) :: known
        if (run%first == 0) then
            run%first = correction
            if (run%renewed) then
                self%steps_since_measured = self%steps_since_measured + 1
                known = self%learned_rate
                if (self%steps_since_measured >= 16) known = 1
            else
                known = run%low_rate
            end if
            if (action == ACTION_ITERATE .and. predicted_within(known, correction, &
                    run%settings%tolerance, rate_margin)) action = ACTION_CONVERGED
        else if (run%renewed) then
            if (run%first > 0) self%learned_rate = correction / run%first
            self%steps_since_measured = 0
            run%renewed = .false.
        end if
        if (run%first /= correction) run%watch = run%renewed
    end subroutine first_corrections

    !> delta = the Newton correction for the residual f_low; its size relative to the
    !! state (`scale`).
    real(wp) function newton_correction(self, scale) result(correction)
        class(reduced_step_t), intent(inout) :: self
        real(wp), intent(in) :: scale
        self%delta = self%f_low
        call self%factors%solve(self%delta)
        correction = maxval(abs(self%delta)) / scale
    end function newton_correction

    !> Form and factor the Newton matrix at self%x from the evaluation just made there
    !! (real64 or working precision).
    subroutine refactor(self, run, lowered, report, status)
        class(reduced_step_t), intent(inout) :: self
        type(solve_t), intent(in) :: run
        logical, intent(in) :: lowered
        type(reduced_report_t), intent(inout) :: report
        type(holosym_status_t), intent(out) :: status
        integer :: info
        call self%scheme%form_jacobian(lowered, status)
        if (.not. status%ok()) return
        call self%factors%factor(self%scheme%layout%jac_start, self%scheme%layout%jac_col, &
                                 self%scheme%jac_values, info, &
                                 real(run%settings%pivot_tolerance, dp))
        report%factorizations = report%factorizations + 1
        if (info /= 0) then
            self%singular_x = self%x
            self%have_singular_x = .true.
            call set_status(status, HOLOSYM_SINGULAR_MATRIX, "reduced Newton matrix " // &
                "singular at pivot " // int_str(info) // " of " // int_str(self%scheme%nx))
            return
        end if
        self%factors_h = run%h
    end subroutine refactor

    !> Whether every finite entry of `values` is within the range of real64, so that
    !! converting it cannot overflow (NaN and Inf convert as they are; they are not
    !! compared, which would raise 'invalid').
    pure logical function fits_real64(values) result(fits)
        real(wp), intent(in) :: values(:)
        integer :: k
        fits = .true.
        do k = 1, size(values)
            if (.not. ieee_is_finite(values(k))) cycle
            if (abs(values(k)) > huge(1.0_dp)) then
                fits = .false.
                return
            end if
        end do
    end function fits_real64

    !> Make the last solution (`x`, from q with step h) the previous step of the next solve.
    subroutine step_accept(self, q, h)
        class(reduced_step_t), intent(inout) :: self
        real(wp), intent(in) :: q(:) !! start coordinates of the solved step
        real(wp), intent(in) :: h    !! its step size
        self%last_x = self%x
        self%last_qa = q
        self%last_h = h
        self%have_last = .true.
    end subroutine step_accept

    !> What to do after a Newton correction of relative size `correction` (`previous`: the
    !! one before with the same factors, huge when none; `last_rate`: the contraction
    !! before that, 0 when none):
    !! - CONVERGED when the correction, or the error predicted from the contraction rate
    !!   theta, theta / (1 - theta) correction with theta the larger of the last two rates
    !!   (with the margin `rate_margin`), is within `target`; or when corrections stop
    !!   decreasing (by `stagnation_rate`) below `floor` (round-off);
    !! - REFACTOR, far from the target, when factors formed at an earlier iterate contract
    !!   worse than `settings`' contraction limit or too slowly to reach it soon
    !!   (`slow_iterations`);
    !! - DIVERGED after `settings%max_growth` growing corrections with fresh factors;
    !! - else ITERATE.
    integer function next_action(correction, previous, last_rate, target, floor, fresh, &
                                 settings, growth) result(action)
        real(wp), intent(in) :: correction, previous, last_rate, target, floor
        logical, intent(in) :: fresh   !! the factors were formed in this solve
        type(newton_settings_t), intent(in) :: settings !! max_growth, contraction_limit
        integer, intent(inout) :: growth
        real(wp) :: rate
        action = ACTION_ITERATE
        if (.not. is_finite(correction)) then
            growth = settings%max_growth
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
            if (kept_factors_stale(rate, correction, target, &
                                   contraction_limit_of(settings, banded_contraction_limit))) then
                action = ACTION_REFACTOR
                return
            end if
        end if
        growth = growth_after(rate, growth, .true.)
        if (growth >= settings%max_growth) action = ACTION_DIVERGED
    end function next_action

end module holosym_reduced_step
