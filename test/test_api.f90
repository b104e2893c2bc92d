!> Tests of the public API as a user sees it: everything a user calls comes from
!! `use holosym` alone (the list below fails to compile when the façade loses a name), the
!! building blocks under it from `use holosym_internal`, the documented keyword names of
!! `init` and `orders` work, and the types and procedures the façade adds to the integrator
!! (work counters, difference Hessians, RATTLE) are usable through it.
module test_api
    use holosym, only: wp, dp, wp_is_double, holosym_status_t, status_code_name, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, &
        HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
        gauss_legendre, gauss_lobatto, lagrange_values, lagrange_derivatives, &
        lagrange_matrices, constrained_hamiltonian, difference_hessian, &
        difference_constraint_hessian, manifold_residuals, manifold_tolerance_default, &
        full_rank_constraints, project_to_manifold, projection_report_t, &
        projection_max_iterations_default, spherical_pendulum, spring_linkage, &
        planar_pendulum, newton_settings_t, constrained_integrator, step_info_t, &
        step_observer, integrator_stats_t, rattle_integrator, rattle_stats_t, &
        composition_coefficients, rattle_max_order
    use holosym_internal, only: lu_factor, lu_solve, default_pivot_tolerance, lu_factor_dp, &
        lu_solve_dp, default_pivot_tolerance_dp, nonlinear_system, newton_solve, &
        newton_report_t, newton_workspace_t, LINEAR_SOLVER_NATIVE, LINEAR_SOLVER_MIXED, &
        discrete_scheme, scheme_counters_t, unknown_count, JACOBIAN_ASSEMBLED, &
        JACOBIAN_RESIDUAL_DIFFERENCES, HESSIANS_USER, HESSIANS_DIFFERENCES
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close
    implicit none
    private
    public :: api_tests

contains

    !> The tests of this suite.
    function api_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("init_and_orders_with_documented_keywords", keyword_init), &
            new_test("work_counters_through_the_facade", work_counters), &
            new_test("difference_hessians_through_the_facade", difference_hessians), &
            new_test("rattle_through_the_facade", rattle), &
            new_test("scheme_and_newton_through_holosym_internal", scheme_and_newton)]
    end function api_tests

    !> `init(sys, M=2, N=1, G=3)` as the documentation writes it sets up the same scheme as
    !! the positional call (same step to the last bit); `orders(M=, N=, G=)` reads it back.
    subroutine keyword_init(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: by_keyword, by_position
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), q2(3), p2(3)
        integer :: order_m, order_n, gauss
        sys = spherical_pendulum()
        call by_keyword%init(sys, M=2, N=1, G=3, status=status)
        call check(error, status%ok(), "init with keywords: " // status%message)
        call by_keyword%orders(M=order_m, N=order_n, G=gauss)
        call check(error, order_m == 2 .and. order_n == 1 .and. gauss == 3, "orders")
        call by_position%init(sys, 2, 1, 3, status)
        call sys%initial_state(q, p)
        q2 = q
        p2 = p
        call by_keyword%step(sys, q, p, 0.125_wp, status=status)
        call by_position%step(sys, q2, p2, 0.125_wp, status=status)
        call check(error, all(q == q2) .and. all(p == p2), "the same step")
        call by_keyword%init(sys, G=1, N=1, M=1, status=status)
        call check(error, status%code == HOLOSYM_INVALID_ORDER, "keywords in any order " // &
            "reach their dummies (G = 1 <= N = 1 is rejected): " // status_code_name(status%code))
    end subroutine keyword_init

    !> `integrator_stats_t` (the type of `stats`) counts the work of a run.
    subroutine work_counters(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(integrator_stats_t) :: stats
        type(step_info_t) :: info
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call integ%init(sys, M=2, N=1, G=3)
        call integ%integrate(sys, q, p, 0.125_wp, 4)
        stats = integ%stats
        info = integ%last_step()
        call check(error, stats%steps == 4 .and. stats%newton_iterations >= 4 .and. &
            stats%residual_evaluations > 0, "counters of 4 steps")
        call check(error, info%newton_iterations > 0, "last step's diagnostics")
    end subroutine work_counters

    !> The default (difference) Hessians agree with the pendulum's exact ones to the
    !! accuracy of central differences (step eps**(1/3): error about eps**(2/3)).
    subroutine difference_hessians(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        real(wp) :: q(3), p(3), exact(3, 3, 3), approx(3, 3, 3), phi_exact(3, 3, 1)
        real(wp) :: phi_approx(3, 3, 1), tolerance
        tolerance = 100 * epsilon(1.0_wp)**(2.0_wp / 3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call sys%hessian(q, p, exact(:, :, 1), exact(:, :, 2), exact(:, :, 3))
        call difference_hessian(sys, q, p, approx(:, :, 1), approx(:, :, 2), approx(:, :, 3))
        call check(error, maxval(abs(exact - approx)) <= tolerance, "difference_hessian")
        call sys%constraint_hessian(q, phi_exact)
        call difference_constraint_hessian(sys, q, phi_approx)
        call check(error, maxval(abs(phi_exact - phi_approx)) <= tolerance, &
            "difference_constraint_hessian")
    end subroutine difference_hessians

    !> RATTLE, its compositions and its counters are reachable through the façade.
    subroutine rattle(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(rattle_integrator) :: integ
        type(rattle_stats_t) :: stats
        type(holosym_status_t) :: status
        real(wp), allocatable :: gammas(:)
        real(wp) :: q(3), p(3)
        call composition_coefficients(4, "triple-jump", gammas, status)
        call check(error, status%ok() .and. size(gammas) == 3, "triple jump: 3 stages")
        if (allocated(error)) return
        call check_close(error, sum(gammas), 1.0_wp, 8 * epsilon(1.0_wp), 0.0_wp, &
            "stages sum to 1")
        call composition_coefficients(rattle_max_order + 2, "suzuki", gammas, status)
        call check(error, status%code == HOLOSYM_INVALID_ORDER, "order above rattle_max_order")
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call integ%init(sys, 4, "suzuki", status)
        call integ%step(sys, q, p, 0.125_wp, status)
        stats = integ%stats
        call check(error, status%ok() .and. stats%steps == 1, "one RATTLE step counted")
    end subroutine rattle

    !> The scheme and Newton's method, the layer below the integrator, through
    !! holosym_internal: the first step solved directly matches the integrator's step to
    !! round-off.
    subroutine scheme_and_newton(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(discrete_scheme) :: scheme
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q(3), p(3), q_b(3), p_b(3)
        real(wp), allocatable :: x(:)
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        call scheme%init(2, 1, 3, sys%n, sys%m, status)
        call check(error, status%ok() .and. scheme%nx == unknown_count(2, 1, 3, 1) .and. &
            scheme%jacobian_mode == JACOBIAN_ASSEMBLED .and. &
            scheme%hessian_mode == HESSIANS_USER, "scheme set up, default modes")
        if (allocated(error)) return
        allocate (x(scheme%nx))
        call scheme%set_step(sys, q0, p0, 0.125_wp)
        call scheme%constant_guess(x)
        call newton_solve(scheme, x, settings, 1.0_wp, report, status)
        call check(error, status%ok() .and. report%iterations > 0, "Newton solves the step")
        if (allocated(error)) return
        call scheme%increments(x, q_b, p_b, status)
        q = q0
        p = p0
        call integ%init(sys, M=2, N=1, G=3)
        call integ%step(sys, q, p, 0.125_wp)
        call check(error, maxval(abs(q0 + q_b - q)) <= 64 * epsilon(1.0_wp) .and. &
            maxval(abs(p0 + p_b - p)) <= 64 * epsilon(1.0_wp), "the integrator's step")
    end subroutine scheme_and_newton

end module test_api
