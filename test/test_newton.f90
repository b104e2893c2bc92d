!> Tests of the Newton policy (`holosym_newton_policy`): each decision on hand-computed
!! cases (predicted convergence, stagnation, growth, the cost models of refactoring, stale
!! factors), the settings that reach it acting on `newton_solve`, and the iteration on kept
!! real64 factors (`kept_newton_solve`) on the same systems.
module test_newton
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, HOLOSYM_SUCCESS, &
        HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_SINGULAR_MATRIX
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf
    use holosym_newton, only: nonlinear_system, newton_settings_t, newton_report_t, &
        newton_solve, newton_workspace_t, fits_real64
    use holosym_float_bits, only: all_below_exponent
    use holosym_newton_policy, only: corrections_needed, predicted_within, stagnated, &
        growth_after, refactor_pays, renewal_pays, slow_iterations, kept_factors_stale, &
        rate_margin, presolve_tolerance, presolve_floor
    use holosym_kept_newton, only: kept_newton_t, kept_report_t, kept_newton_solve
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: newton_tests

    !> F(x) = (x1^2 + x2^2 - 4, exp(x1) + x2 - 1) (a circle and an exponential meet at
    !! about (1.004, -1.729)); its Jacobian is exact.
    type, extends(nonlinear_system) :: circle_exponential
    contains
        procedure :: residual => circle_residual
        procedure :: jacobian => circle_jacobian
    end type circle_exponential

    !> F(x) = atan(x): Newton's iterates x - (1 + x^2) atan(x) from x = 2 alternate in sign
    !! and grow (-3.54, 13.95, -279.3, ...).
    type, extends(nonlinear_system) :: arctangent
    contains
        procedure :: residual => atan_residual
        procedure :: jacobian => atan_jacobian
    end type arctangent

contains

    !> The tests of this suite.
    function newton_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("predicted_convergence", predicted_convergence), &
            new_test("stagnation_at_round_off", stagnation), &
            new_test("growth_counts_to_divergence", growth), &
            new_test("corrections_needed_by_rate", needed), &
            new_test("refactor_cost_model", refactor_cost_model), &
            new_test("renewal_cost_model", renewal_cost_model), &
            new_test("stale_and_slow_factors", stale_factors), &
            new_test("presolve_targets_as_documented", presolve_targets), &
            new_test("settings_act_on_newton_solve", settings_act), &
            new_test("growing_corrections_diverge", diverges), &
            new_test("kept_factors_solve_and_are_kept", kept_factors), &
            new_test("kept_factors_settings_act", kept_settings), &
            new_test("range_checks_by_exponent_bits", range_checks) &
        ]
    end function newton_tests

    !> The error left after a correction c with contraction theta is theta / (1 - theta) c:
    !! 1e-10 for theta = 0.5, c = 1e-10; within a target of 1e-10 with margin 1, not with
    !! margin 8 (which needs 8e-10); never for theta >= 1.
    subroutine predicted_convergence(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check(error, predicted_within(0.5_wp, 1.0e-10_wp, 1.0e-10_wp, 1.0_wp), &
            "theta 0.5: error 1e-10 within 1e-10")
        call check(error, .not. predicted_within(0.5_wp, 1.0e-10_wp, 1.0e-10_wp, rate_margin), &
            "margin 8 asks for 8e-10")
        call check(error, predicted_within(0.5_wp, 1.0e-10_wp, 8.0e-10_wp, rate_margin), &
            "margin 8 met at 8e-10")
        call check(error, .not. predicted_within(0.9_wp, 1.0e-10_wp, 8.0e-10_wp, 1.0_wp), &
            "theta 0.9 leaves 9e-10")
        call check(error, .not. predicted_within(1.0_wp, 1.0e-30_wp, 1.0_wp, 1.0_wp), &
            "theta 1 never converges")
        call check(error, .not. predicted_within(3.0_wp, 1.0e-30_wp, 1.0_wp, 1.0_wp), &
            "growing corrections never converge")
    end subroutine predicted_convergence

    !> A correction at or below the round-off floor that shrank by less than the least
    !! factor asked for has stagnated; one above the floor never has.
    subroutine stagnation(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check(error, stagnated(1.0_wp, 1.0e-30_wp, 1.0e-22_wp, 1.0_wp), &
            "no decrease below the floor")
        call check(error, .not. stagnated(0.9_wp, 1.0e-30_wp, 1.0e-22_wp, 1.0_wp), &
            "still decreasing (least 1)")
        call check(error, stagnated(0.6_wp, 1.0e-30_wp, 1.0e-22_wp, 0.5_wp), &
            "shrinking by 0.6 only (least 0.5)")
        call check(error, .not. stagnated(0.4_wp, 1.0e-30_wp, 1.0e-22_wp, 0.5_wp), &
            "shrinking by 0.4 (least 0.5)")
        call check(error, .not. stagnated(2.0_wp, 1.0e-20_wp, 1.0e-22_wp, 1.0_wp), &
            "above the floor")
        call check(error, stagnated(1.0_wp, 1.0e-22_wp, 1.0e-22_wp, 1.0_wp), &
            "at the floor")
    end subroutine stagnation

    !> Growing corrections count up (three in a row reach the default max_growth 3), a
    !! decreasing one resets the count; an equal one grows only when asked to.
    subroutine growth(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: count, k
        count = 0
        do k = 1, 3
            count = growth_after(1.5_wp, count, .false.)
        end do
        call check(error, count == 3, "three growing corrections: " // int_str(count))
        call check(error, growth_after(0.3_wp, count, .false.) == 0, "a decrease resets")
        call check(error, growth_after(1.0_wp, 2, .false.) == 0, "equal: no growth")
        call check(error, growth_after(1.0_wp, 2, .true.) == 3, "equal grows when asked")
    end subroutine growth

    !> From 1 to 1e-6 at rate 0.1: six corrections; from 1e-10 to 1e-12 at rate 0.5:
    !! log(0.01) / log(0.5) = 6.64.
    subroutine needed(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check(error, abs(corrections_needed(0.1_wp, 1.0_wp, 1.0e-6_wp) - 6) < 1.0e-12_dp, &
            "rate 0.1, 1 -> 1e-6: " // real_str(real(corrections_needed(0.1_wp, 1.0_wp, &
            1.0e-6_wp), wp)))
        call check(error, abs(corrections_needed(0.5_wp, 1.0e-10_wp, 1.0e-12_wp) - &
            6.643856189774724_dp) < 1.0e-12_dp, "rate 0.5, 1e-10 -> 1e-12")
    end subroutine needed

    !> Kept factors contracting by 0.5 leave an error of 1e-6 after a correction of 1e-6
    !! and need log(1e-24)/log(0.5) = 80 corrections to 1e-30; fresh ones (kappa 1: rate
    !! 1e-6) need 4 plus the Jacobian's cost of 2: refactor. With kappa unknown, a target
    !! already met, or fresh factors no better than the kept ones: keep them. A cost of
    !! 100 residuals outweighs the 80 - 4 saved.
    subroutine refactor_cost_model(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp), parameter :: floor = 1.0e-32_wp
        call check(error, refactor_pays(0.5_wp, 1.0e-6_wp, 1.0_wp, floor, 1.0e-30_wp, 2.0_wp), &
            "fresh factors save 74 residuals")
        call check(error, .not. refactor_pays(0.5_wp, 1.0e-6_wp, 1.0_wp, floor, 1.0e-30_wp, &
            100.0_wp), "a cost of 100 residuals outweighs them")
        call check(error, .not. refactor_pays(0.5_wp, 1.0e-6_wp, 0.0_wp, floor, 1.0e-30_wp, &
            2.0_wp), "kappa unknown")
        call check(error, .not. refactor_pays(0.5_wp, 1.0e-31_wp, 1.0_wp, floor, 1.0e-30_wp, &
            2.0_wp), "target already met")
        call check(error, .not. refactor_pays(1.0e-3_wp, 1.0e-6_wp, 1.0e6_wp, floor, &
            1.0e-30_wp, 2.0_wp), "fresh factors (kappa e = 1.001e-3) no better than kept (1e-3)")
        call check(error, .not. refactor_pays(1.5_wp, 1.0e-6_wp, 1.0_wp, floor, 1.0e-30_wp, &
            2.0_wp), "growing corrections: the growth test decides, not the cost model")
    end subroutine refactor_cost_model

    !> At the end of the real64 phase (correction 1e-13, tolerance 1.5e-33): kept factors
    !! contracting by 1e-3 need ceiling(log(1.5e-20)/log(1e-3)) = 7 corrections, renewed ones
    !! (1e-12) 2, plus a cost of 1: renew. Kept factors at 1e-16 need 2: keep them. Corrections
    !! that grow: renew; a tolerance met: keep.
    subroutine renewal_cost_model(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check(error, renewal_pays(1.0e-3_wp, 1.0e-13_wp, 1.5e-33_wp, 1.0_wp), &
            "rate 1e-3: 7 against 2 + 1")
        call check(error, .not. renewal_pays(1.0e-16_wp, 1.0e-13_wp, 1.5e-33_wp, 1.0_wp), &
            "rate 1e-16: 2 against 2 + 1")
        call check(error, .not. renewal_pays(1.0e-3_wp, 1.0e-13_wp, 1.5e-33_wp, 5.0_wp), &
            "rate 1e-3 with a cost of 5: 7 against 2 + 5")
        call check(error, renewal_pays(1.0_wp, 1.0e-13_wp, 1.5e-33_wp, 1.0_wp), &
            "no contraction: renew")
        call check(error, .not. renewal_pays(0.5_wp, 1.0e-34_wp, 1.5e-33_wp, 1.0_wp), &
            "tolerance met")
    end subroutine renewal_cost_model

    !> Kept factors are stale far from the target (more than 64 times it) when they
    !! contract worse than the limit or need more than 4 further corrections; near the
    !! target they finish the solve.
    subroutine stale_factors(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check(error, slow_iterations(0.5_wp, 1.0e-10_wp, 1.0e-12_wp), &
            "6.6 corrections at rate 0.5")
        call check(error, .not. slow_iterations(0.1_wp, 1.0e-10_wp, 1.0e-12_wp), &
            "2 corrections at rate 0.1")
        call check(error, kept_factors_stale(0.2_wp, 1.0e-6_wp, 1.0e-12_wp, 0.1_wp), &
            "rate 0.2 beyond the limit 0.1")
        call check(error, .not. kept_factors_stale(0.05_wp, 1.0e-10_wp, 1.0e-12_wp, 0.1_wp), &
            "rate 0.05: 1.5 corrections to go")
        call check(error, kept_factors_stale(0.09_wp, 1.0e-6_wp, 1.0e-12_wp, 0.1_wp), &
            "rate 0.09 from 1e-6: 5.7 corrections to go")
        call check(error, .not. kept_factors_stale(0.9_wp, 6.0e-11_wp, 1.0e-12_wp, 0.1_wp), &
            "within 64 times the target: finish with these factors")
    end subroutine stale_factors

    !> The pre-solve's target is eps_64^(5/8), about 1.65e-10, and its floor eps_64^(1/2),
    !! about 1.49e-8 (the values its documentation gives).
    subroutine presolve_targets(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check(error, presolve_tolerance > 1.6e-10_wp .and. presolve_tolerance < 1.7e-10_wp, &
            "presolve_tolerance " // real_str(presolve_tolerance))
        call check(error, presolve_floor > 1.4e-8_wp .and. presolve_floor < 1.5e-8_wp, &
            "presolve_floor " // real_str(presolve_floor))
    end subroutine presolve_targets

    !> On the circle and the exponential, simplified Newton from (1, -1.5) converges to
    !! the same root to the tolerance; a contraction limit near 0 renews the factors at
    !! every iteration (as many factorisations as iterations), the default fewer; one
    !! iteration allowed is not enough.
    subroutine settings_act(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(circle_exponential) :: sys
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report(2)
        type(holosym_status_t) :: status
        real(wp) :: x(2, 2)
        integer :: trial
        do trial = 1, 2
            settings = newton_settings_t(simplified=.true.)
            if (trial == 2) settings%contraction_limit = 1.0e-30_wp
            x(:, trial) = [1.0_wp, -1.5_wp]
            call newton_solve(sys, x(:, trial), settings, 1.0_wp, report(trial), status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "trial " // &
                int_str(trial))
            if (allocated(error)) return
        end do
        call check(error, maxval(abs(x(:, 1) - x(:, 2))) <= max(1.0e-30_wp, 64 * epsilon(1.0_wp)), &
            "roots differ by " &
            // real_str(maxval(abs(x(:, 1) - x(:, 2)))))
        call check(error, report(1)%factorizations < report(1)%iterations, "default: " // &
            int_str(report(1)%factorizations) // " factorisations for " // &
            int_str(report(1)%iterations) // " iterations")
        call check(error, report(2)%factorizations > report(1)%factorizations, &
            "contraction_limit 1e-30: " // int_str(report(2)%factorizations) // &
            " factorisations, default " // int_str(report(1)%factorizations))
        settings = newton_settings_t(simplified=.true., max_iterations=1)
        x(:, 1) = [1.0_wp, -1.5_wp]
        call newton_solve(sys, x(:, 1), settings, 1.0_wp, report(1), status)
        call check(error, .not. status%ok(), "one iteration converged")
        call check(error, all(x(:, 1) == [1.0_wp, -1.5_wp]), "first guess not restored")
    end subroutine settings_act

    !> atan(x) = 0 from x = 2 with scale 1e6 (so that the corrections 5.54, 17.5, 293 are
    !! measured against the same scale): the second and the third grow, and with
    !! max_growth = 2 the solve stops at iteration 3 with HOLOSYM_NEWTON_DIVERGED, the
    !! first guess restored.
    subroutine diverges(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(arctangent) :: sys
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report
        type(holosym_status_t) :: status
        real(wp) :: x(1)
        x = 2
        settings = newton_settings_t(max_growth=2, max_iterations=200)
        call newton_solve(sys, x, settings, 1.0e6_wp, report, status)
        call check_status_code(error, status%code, HOLOSYM_NEWTON_DIVERGED, "atan from 2")
        call check(error, report%iterations == 3, "stopped after " // &
            int_str(report%iterations) // " iterations, expected 3")
        call check(error, x(1) == 2, "first guess not restored")
    end subroutine diverges

    !> `kept_newton_solve` (the reduced step's iteration) on the circle and the
    !! exponential, with the default dense Newton matrix of `nonlinear_system`: from
    !! (1, -1.5) it reaches the root `newton_solve` finds, to the tolerance; a second solve
    !! from a guess 1e-3 away starts with the kept factors and forms fewer; after `forget`
    !! the first solve's work is repeated exactly.
    subroutine kept_factors(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(circle_exponential) :: sys
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report
        type(kept_newton_t) :: state
        type(kept_report_t) :: work(3)
        type(holosym_status_t) :: status
        real(wp) :: root(2), x(2)
        integer :: trial
        root = [1.0_wp, -1.5_wp]
        call newton_solve(sys, root, settings, 1.0_wp, report, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "newton_solve")
        if (allocated(error)) return
        call state%setup(2, 1, 1)
        do trial = 1, 3
            x = [1.0_wp, -1.5_wp]
            if (trial == 2) x = root + 1.0e-3_wp
            if (trial == 3) call state%forget()
            call kept_newton_solve(sys, x, state, settings, 1.0_wp, 1.0e-20_wp, work(trial), &
                                   status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "solve " // &
                int_str(trial) // ": " // status%message)
            if (allocated(error)) return
            call check(error, maxval(abs(x - root)) <= 64 * epsilon(1.0_wp), "solve " // &
                int_str(trial) // " ends " // real_str(maxval(abs(x - root))) // &
                " from newton_solve's root")
        end do
        call check(error, work(2)%factorizations < work(1)%factorizations .and. &
            work(3)%factorizations == work(1)%factorizations .and. &
            work(3)%iterations == work(1)%iterations, "factorisations per solve: " // &
            int_str(work(1)%factorizations) // ", " // int_str(work(2)%factorizations) // &
            ", " // int_str(work(3)%factorizations) // "; iterations " // &
            int_str(work(1)%iterations) // ", " // int_str(work(3)%iterations) // &
            " (expected fewer in the second, the first's again after forget)")
    end subroutine kept_factors

    !> Failures of `kept_newton_solve`: one iteration allowed does not converge from
    !! (1, -1.5) (HOLOSYM_NEWTON_NOT_CONVERGED); on atan(x) from x = 2 the iterates grow
    !! (-3.5, 14, -279, ...) with factors renewed at each one, until the Newton matrix
    !! 1 / (1 + x^2) falls below the pivot threshold: HOLOSYM_SINGULAR_MATRIX, with the
    !! iterate where it did (`singular_x`, finite) kept for the caller's diagnosis.
    subroutine kept_settings(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(circle_exponential) :: circle
        type(arctangent) :: arc
        type(kept_newton_t) :: state
        type(kept_report_t) :: work
        type(holosym_status_t) :: status
        real(wp) :: x(2), y(1)
        call state%setup(2, 1, 1)
        x = [1.0_wp, -1.5_wp]
        call kept_newton_solve(circle, x, state, newton_settings_t(max_iterations=1), &
                               1.0_wp, 1.0e-20_wp, work, status)
        call check_status_code(error, status%code, HOLOSYM_NEWTON_NOT_CONVERGED, &
            "one iteration")
        if (allocated(error)) return
        call state%setup(1, 0, 0)
        y = 2
        work = kept_report_t()
        call kept_newton_solve(arc, y, state, newton_settings_t(max_growth=2, &
                               max_iterations=200), 1.0e6_wp, 1.0e-20_wp, work, status)
        call check_status_code(error, status%code, HOLOSYM_SINGULAR_MATRIX, "atan from 2: " &
            // status%message)
        if (allocated(error)) return
        call check(error, state%have_singular_x .and. abs(state%singular_x(1)) > 100 .and. &
            abs(state%singular_x(1)) < huge(1.0_dp), "singular at x = " // &
            real_str(state%singular_x(1)))
    end subroutine kept_settings

    !> The range checks read from the exponent bits: 2^1022 and -2^1022 fit real64,
    !! 2^1023 (beyond which a conversion may overflow) and -huge do not; NaN and Inf pass
    !! (their own checks report them); an empty set passes; all_below_exponent with limit
    !! 10 takes 1023.99 (2^9.99...) but not 1024 = 2^10, nor -1024, and looks at the
    !! first `count` values only.
    subroutine range_checks(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: nan, inf, none(0)
        nan = ieee_value(nan, ieee_quiet_nan)
        inf = ieee_value(inf, ieee_positive_inf)
        call check(error, fits_real64([2.0_wp**1022, -2.0_wp**1022, 0.0_wp, tiny(1.0_wp)]), &
            "2^1022 does not fit")
        call check(error, .not. fits_real64([1.0_wp, 2.0_wp**1023]), "2^1023 fits")
        call check(error, .not. fits_real64([-huge(1.0_wp)]), "-huge fits")
        call check(error, fits_real64([nan, inf, -inf, 1.0_wp]), "NaN or Inf rejected")
        call check(error, fits_real64(none), "empty set rejected")
        call check(error, all_below_exponent([1023.99_wp, -1.0_wp], 2, 10), "1023.99 >= 2^10")
        call check(error, .not. all_below_exponent([1.0_wp, 1024.0_wp], 2, 10), "1024 < 2^10")
        call check(error, .not. all_below_exponent([-1024.0_wp], 1, 10), "-1024 < 2^10")
        call check(error, all_below_exponent([1.0_wp, 1024.0_wp], 1, 10), "count ignored")
    end subroutine range_checks

    subroutine circle_residual(self, x, f, status)
        class(circle_exponential), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(wp), intent(out) :: f(:)
        type(holosym_status_t), intent(out) :: status
        f = [x(1)**2 + x(2)**2 - 4, exp(x(1)) + x(2) - 1]
        status%code = HOLOSYM_SUCCESS
    end subroutine circle_residual

    subroutine circle_jacobian(self, x, jac, status)
        class(circle_exponential), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(wp), intent(out) :: jac(:, :)
        type(holosym_status_t), intent(out) :: status
        jac = reshape([2 * x(1), exp(x(1)), 2 * x(2), 1.0_wp], [2, 2])
        status%code = HOLOSYM_SUCCESS
    end subroutine circle_jacobian

    subroutine atan_residual(self, x, f, status)
        class(arctangent), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(wp), intent(out) :: f(:)
        type(holosym_status_t), intent(out) :: status
        f = atan(x)
        status%code = HOLOSYM_SUCCESS
    end subroutine atan_residual

    subroutine atan_jacobian(self, x, jac, status)
        class(arctangent), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(wp), intent(out) :: jac(:, :)
        type(holosym_status_t), intent(out) :: status
        jac(1, 1) = 1 / (1 + x(1)**2)
        status%code = HOLOSYM_SUCCESS
    end subroutine atan_jacobian

end module test_newton
