!> holosym: high-order symplectic integration of Hamiltonian systems with holonomic
!! constraints, in quadruple precision. `use holosym` gives the whole public API.
module holosym
    use holosym_kinds, only: wp, dp
    use holosym_release, only: holosym_version
    use holosym_status, only: holosym_status_t, status_code_name, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, &
        HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS
    use holosym_quadrature, only: gauss_legendre, gauss_lobatto
    use holosym_lagrange, only: lagrange_values, lagrange_derivatives, lagrange_matrices
    use holosym_linalg, only: lu_factor, lu_solve, default_pivot_tolerance
    use holosym_problem, only: constrained_hamiltonian
    use holosym_newton, only: newton_settings_t, newton_report_t
    use holosym_scheme, only: unknown_count
    use holosym_manifold, only: manifold_residuals, manifold_tolerance_default, &
        full_rank_constraints
    use holosym_integrator, only: constrained_integrator, step_info_t, step_observer
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_projection, only: project_to_manifold, projection_report_t, &
        projection_max_iterations_default
    implicit none
    public
end module holosym
