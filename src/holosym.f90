!> The public API of holosym: `use holosym` gives everything a user needs, and only that.
!!
!! High-order symplectic integration of Hamiltonian systems with holonomic constraints,
!! in quadruple precision. The other modules are internal: the public entities users need
!! are re-exported here, and the pages of the modules that define them document them.
!!
!! - [[holosym_kinds:wp]], `dp`: the working kind (real128, or real64 with
!!   `-DHOLOSYM_REAL64`) and real64.
!! - [[holosym_release:holosym_version]]: the library's version, "MAJOR.MINOR.PATCH".
!! - [[constrained_hamiltonian]]: the abstract type a user extends with H, its gradients,
!!   the constraints phi and their Jacobian Phi; second derivatives are optional.
!! - [[constrained_integrator]]: `init`, `step`, `integrate`, `dense_output`, the speed
!!   options and the work counters `stats`.
!! - [[step_info_t]], [[step_observer]]: diagnostics of one step; the observer that
!!   `integrate` calls after each step.
!! - [[newton_settings_t]], [[newton_report_t]]: the Newton settings of an integrator
!!   (`integ%newton`) and what one solve did.
!! - [[unknown_count]]: the number of unknowns of one step for (M, N, G, n, m).
!! - [[project_to_manifold]], [[projection_report_t]],
!!   `projection_max_iterations_default`: moves a nearby state onto the manifold.
!! - [[manifold_residuals]], [[full_rank_constraints]], `manifold_tolerance_default`:
!!   the constraint residuals of a state; the rank test of Phi.
!! - [[spherical_pendulum]], [[spring_linkage]], [[planar_pendulum]]: the paper's
!!   example systems and a planar pendulum.
!! - [[gauss_legendre]], [[gauss_lobatto]]: quadrature rules on [0, 1].
!! - [[lagrange_values]], [[lagrange_derivatives]], [[lagrange_matrices]]: the Lagrange
!!   basis on given nodes.
!! - [[lu_factor]], [[lu_solve]], [[default_pivot_tolerance]]: LU factorisation with
!!   partial pivoting in working precision.
!! - [[holosym_status_t]], [[status_code_name]]: the status returned through the optional
!!   `status` argument of every fallible procedure; the name of a code.
!! - `HOLOSYM_SUCCESS`, `HOLOSYM_INVALID_ORDER`, `HOLOSYM_INVALID_DIMENSION`,
!!   `HOLOSYM_SIZE_MISMATCH`, `HOLOSYM_INVALID_STEP_SIZE`, `HOLOSYM_INVALID_STEP_COUNT`,
!!   `HOLOSYM_OFF_MANIFOLD`, `HOLOSYM_USER_ABORT`, `HOLOSYM_NOT_INITIALIZED`,
!!   `HOLOSYM_INVALID_ARGUMENT`, `HOLOSYM_SINGULAR_MATRIX`, `HOLOSYM_NEWTON_NOT_CONVERGED`,
!!   `HOLOSYM_NEWTON_DIVERGED`, `HOLOSYM_NONFINITE_VALUE`,
!!   `HOLOSYM_RANK_DEFICIENT_CONSTRAINTS`: the status codes (0 success, negative invalid
!!   input, positive numerical failure; see [[holosym_status]]).
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
