!> holosym: high-order symplectic integration of Hamiltonian systems with holonomic
!! constraints, in quadruple precision. `use holosym` gives the whole public API; the other
!! modules of the library are its parts and need not be used directly.
!!
!! Left out on purpose: the message helpers of holosym_status (`set_status`, `int_str`,
!! `real_str`, `is_finite`), the finiteness checks of holosym_newton (`all_finite`,
!! `all_finite_matrix`) and the kernel modules of the scheme, which only the library uses.
module holosym
    use holosym_kinds, only: wp, dp, wp_is_double
    use holosym_status, only: holosym_status_t, status_code_name, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, &
        HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, HOLOSYM_STEP_TOO_LARGE, &
        HOLOSYM_STEP_TOO_SMALL
    use holosym_quadrature, only: gauss_legendre, gauss_lobatto
    use holosym_lagrange, only: lagrange_values, lagrange_derivatives, lagrange_matrices
    use holosym_linalg, only: lu_factor, lu_solve, default_pivot_tolerance, lu_factor_dp, &
        lu_solve_dp, default_pivot_tolerance_dp
    use holosym_problem, only: constrained_hamiltonian, difference_hessian, &
        difference_constraint_hessian
    use holosym_manifold, only: manifold_residuals, manifold_tolerance_default, &
        full_rank_constraints
    use holosym_projection, only: project_to_manifold, projection_report_t, &
        projection_max_iterations_default
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_newton, only: nonlinear_system, newton_solve, newton_settings_t, &
        newton_report_t, newton_workspace_t, LINEAR_SOLVER_NATIVE, LINEAR_SOLVER_MIXED
    use holosym_scheme, only: discrete_scheme, scheme_counters_t, unknown_count, &
        max_order_m, max_order_n, max_gauss_points, JACOBIAN_ASSEMBLED, &
        JACOBIAN_RESIDUAL_DIFFERENCES, HESSIANS_USER, HESSIANS_DIFFERENCES
    use holosym_integrator, only: constrained_integrator, step_info_t, step_observer, &
        integrator_stats_t
    use holosym_rattle, only: rattle_integrator, rattle_stats_t, composition_coefficients, &
        rattle_max_order
    implicit none
    private

    ! Kinds: working precision (real128, or real64 with -DHOLOSYM_REAL64) and real64.
    public :: wp, dp, wp_is_double
    ! Status of every fallible procedure, its codes and their names.
    public :: holosym_status_t, status_code_name
    public :: HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, &
        HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, &
        HOLOSYM_OFF_MANIFOLD, HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, &
        HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
        HOLOSYM_STEP_TOO_LARGE, HOLOSYM_STEP_TOO_SMALL
    ! Basis: quadrature on [0, 1] and Lagrange polynomials.
    public :: gauss_legendre, gauss_lobatto
    public :: lagrange_values, lagrange_derivatives, lagrange_matrices
    ! The problem: the abstract system to extend, its default (difference) Hessians, the
    ! constraint manifold, projection onto it, and the paper's models.
    public :: constrained_hamiltonian, difference_hessian, difference_constraint_hessian
    public :: manifold_residuals, manifold_tolerance_default, full_rank_constraints
    public :: project_to_manifold, projection_report_t, projection_max_iterations_default
    public :: spherical_pendulum, spring_linkage, planar_pendulum, pendulum_chain
    ! Solvers: dense LU (working precision; real64 through LAPACK) and Newton's method on
    ! any `nonlinear_system`.
    public :: lu_factor, lu_solve, default_pivot_tolerance
    public :: lu_factor_dp, lu_solve_dp, default_pivot_tolerance_dp
    public :: nonlinear_system, newton_solve, newton_settings_t, newton_report_t, &
        newton_workspace_t, LINEAR_SOLVER_NATIVE, LINEAR_SOLVER_MIXED
    ! The discrete equations of one step, with the modes of its Jacobian and Hessians
    ! (`discrete_scheme%jacobian_mode`, `%hessian_mode`; the integrator sets them from its
    ! `jacobian` and `hessians` settings).
    public :: discrete_scheme, scheme_counters_t, unknown_count
    ! Limits of (M, N, G) (HOLOSYM_INVALID_ORDER beyond them; docs/status-codes.md).
    public :: max_order_m, max_order_n, max_gauss_points
    public :: JACOBIAN_ASSEMBLED, JACOBIAN_RESIDUAL_DIFFERENCES, HESSIANS_USER, &
        HESSIANS_DIFFERENCES
    ! The integrator, its per-step diagnostics, observer and work counters.
    public :: constrained_integrator, step_info_t, step_observer, integrator_stats_t
    ! The baseline: RATTLE and its symmetric compositions.
    public :: rattle_integrator, rattle_stats_t, composition_coefficients, rattle_max_order

end module holosym
