!> The public API of holosym: `use holosym` gives everything a user needs, and only that.
!!
!! High-order symplectic integration of Hamiltonian systems with holonomic constraints,
!! in quadruple precision. The other modules are internal: the public entities users need
!! are re-exported here, and the pages of the modules that define them document them.
!! Left out on purpose: the message helpers of holosym_status_codes (`set_status`, `int_str`,
!! `real_str`, `is_finite`), the CSV helper `parse_csv_fields` of holosym_ensemble_files,
!! the text files of holosym_text_file (`text_file_t`, `read_text_lines`), `sorted_order`
!! of holosym_ensemble and the kernel modules of the schemes. The building blocks under the
!! integrator (dense LU, Newton's method, the discrete scheme, the task farm and its
!! records, the lines of the ensemble files) are [[holosym_internal]], with no stability
!! promise.
!!
!! - [[holosym_kinds:wp]], `dp`, `wp_is_double`: the working kind (real128, or real64 with
!!   `-DHOLOSYM_REAL64`), real64, and whether they are the same.
!! - [[holosym_release:holosym_version]]: the library's version, "MAJOR.MINOR.PATCH".
!! - [[constrained_hamiltonian]]: the abstract type a user extends with H, its gradients,
!!   the constraints phi and their Jacobian Phi; second derivatives and the structure
!!   declarations (constant diagonal mass matrix, sparsity) are optional.
!!   [[difference_hessian]], [[difference_constraint_hessian]]: the default second
!!   derivatives (central differences).
!! - [[constrained_integrator]]: `init`, `step`, `integrate`, `step_tangent`,
!!   `dense_output`, the settings and the work counters `stats` ([[integrator_stats_t]]).
!! - [[init_for_accuracy]], [[accuracy_plan_t]], [[accuracy_floor]]: the integrator set up
!!   for a requested error at time T ((M, N, G), h and the Newton tolerance from a pilot;
!!   docs/accuracy.md).
!! - [[integrate_events]], [[event_set]], [[event_t]], `EVENT_ANY`, `EVENT_RISING`,
!!   `EVENT_FALLING`: a run that locates the zero crossings of functions g(t, q, p) of the
!!   motion, to the accuracy of the scheme's steps, and may end at one (docs/events.md);
!!   [[model_events]]: the `event` statements of a model file as such functions;
!!   [[make_section]], [[section_t]]: a surface g(q, p) = 0 stated as an expression of
!!   the model-file grammar, whose crossings an ensemble records (a Poincare section).
!! - [[step_info_t]], [[step_observer]]: diagnostics of one step; the observer that
!!   `integrate` calls after each step, whose component `dense` ([[step_dense_output]])
!!   evaluates the step just taken at any time inside it.
!! - [[trajectory_writer]], [[trajectory_header]]: an observer writing the run as CSV with
!!   the columns of `holosym simulate` (17 or 36 digits, every k steps or at requested
!!   times); [[energy_monitor]]: an observer recording max |dH/H0|, max |phi|,
!!   max |Phi H_p| and Newton iterations (docs/user_system.md).
!! - [[formula_model]], [[load_model]], [[model_from_text]]: a system given by formulas
!!   in a model file, differentiated, structured and compiled by holosym; parameters set
!!   by name, the initial state it states (docs/models.md).
!! - [[check_system]], [[system_check_report_t]], [[check_entry_t]]: a system's
!!   procedures and declarations compared with each other at a state (the integrator runs
!!   it at the first start; docs/user_system.md).
!! - [[state_from_velocities]]: a state on the manifold from positions and velocities.
!! - [[newton_settings_t]]: the Newton settings of an integrator (`integ%newton`);
!!   `default_newton_tolerance`, the default of its `tolerance` (8 epsilon).
!! - `max_order_m`, `max_order_n`, `max_gauss_points`: the limits of M, N and G
!!   (docs/status-codes.md).
!! - [[project_to_manifold]], [[projection_report_t]],
!!   `projection_max_iterations_default`: moves a nearby state onto the manifold.
!! - [[lyapunov_spectrum]], [[lyapunov_result_t]], [[lyapunov_tracker_t]]: Lyapunov
!!   exponents and MEGNO of an
!!   orbit on the manifold, from the tangent map (docs/events.md).
!! - [[project_tangent]], [[tangent_basis]], [[tangent_residual]], `tangent_tolerance`: the
!!   tangent space of the manifold at a state, where `step_tangent` takes its vectors (docs/events.md).
!! - [[manifold_residuals]], [[full_rank_constraints]], `manifold_tolerance_default`:
!!   the constraint residuals of a state; the rank test of Phi.
!! - [[spherical_pendulum]], [[spring_linkage]], [[planar_pendulum]],
!!   [[pendulum_chain]]: the paper's example systems, a planar pendulum and a chain of
!!   planar pendula (the double pendulum for two links); [[sphere_dumbbell]],
!!   [[magnetic_sphere]], [[generic_pendulum]]: two bodies on a sphere joined by a rod, a
!!   charged particle on a sphere in a magnetic field (H not separable), a spherical
!!   pendulum in a potential without symmetry (docs/models.md).
!! - [[rattle_integrator]], [[rattle_stats_t]], [[composition_coefficients]],
!!   `rattle_max_order`: the RATTLE baseline and its symmetric compositions.
!! - [[run_ensemble]], [[ensemble_settings_t]], [[ensemble_states_t]],
!!   [[ensemble_result_t]], [[ensemble_sink]], [[check_ensemble]], [[ensemble_steps]],
!!   [[integrate_member]], [[perturbed_states]]: many trajectories of one system on threads
!!   (or MPI ranks), results by id; [[read_ensemble_states]], [[ensemble_csv_sink]]: their
!!   CSV files (docs/ensemble.md); [[openmp_farm]]: the threads that compute them (the
!!   `farm` argument of `run_ensemble`).
!! - [[gauss_legendre]], [[gauss_lobatto]]: quadrature rules on [0, 1].
!! - [[lagrange_values]], [[lagrange_derivatives]], [[lagrange_matrices]]: the Lagrange
!!   basis on given nodes.
!! - [[holosym_status_t]], [[status_code_name]]: the status returned through the optional
!!   `status` argument of every fallible procedure; the name of a code.
!! - `HOLOSYM_SUCCESS`, `HOLOSYM_INVALID_ORDER`, `HOLOSYM_INVALID_DIMENSION`,
!!   `HOLOSYM_SIZE_MISMATCH`, `HOLOSYM_INVALID_STEP_SIZE`, `HOLOSYM_INVALID_STEP_COUNT`,
!!   `HOLOSYM_OFF_MANIFOLD`, `HOLOSYM_USER_ABORT`, `HOLOSYM_NOT_INITIALIZED`,
!!   `HOLOSYM_INVALID_ARGUMENT`, `HOLOSYM_INVALID_MODEL`, `HOLOSYM_INCONSISTENT_SYSTEM`,
!!   `HOLOSYM_SINGULAR_MATRIX`,
!!   `HOLOSYM_NEWTON_NOT_CONVERGED`, `HOLOSYM_NEWTON_DIVERGED`, `HOLOSYM_NONFINITE_VALUE`,
!!   `HOLOSYM_RANK_DEFICIENT_CONSTRAINTS`, `HOLOSYM_STEP_TOO_LARGE`,
!!   `HOLOSYM_STEP_TOO_SMALL`, `HOLOSYM_OUTSIDE_DOMAIN`: the status codes (0 success, negative invalid input,
!!   positive numerical failure; see [[holosym_status_codes]] and docs/status-codes.md).
module holosym
    use holosym_kinds, only: wp, dp, wp_is_double
    use holosym_release, only: holosym_version
    use holosym_status_codes, only: holosym_status_t, status_code_name, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, &
        HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_INVALID_MODEL, HOLOSYM_INCONSISTENT_SYSTEM, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NONFINITE_VALUE, &
        HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, HOLOSYM_STEP_TOO_LARGE, HOLOSYM_STEP_TOO_SMALL, &
        HOLOSYM_OUTSIDE_DOMAIN
    use holosym_quadrature, only: gauss_legendre, gauss_lobatto
    use holosym_lagrange, only: lagrange_values, lagrange_derivatives, lagrange_matrices
    use holosym_problem, only: constrained_hamiltonian, difference_hessian, &
        difference_constraint_hessian
    use holosym_manifold, only: manifold_residuals, manifold_tolerance_default, &
        full_rank_constraints
    use holosym_tangent_space, only: project_tangent, tangent_residual, tangent_tolerance, &
        tangent_basis
    use holosym_projection, only: project_to_manifold, projection_report_t, &
        projection_max_iterations_default
    use holosym_initial_states, only: state_from_velocities
    use holosym_formula_model, only: formula_model, load_model, model_from_text
    use holosym_system_check, only: check_system, system_check_report_t, check_entry_t
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_model_dumbbell, only: sphere_dumbbell
    use holosym_model_magnetic, only: magnetic_sphere
    use holosym_model_generic, only: generic_pendulum
    use holosym_newton, only: newton_settings_t, default_newton_tolerance
    use holosym_scheme, only: max_order_m, max_order_n, max_gauss_points
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy, accuracy_floor
    use holosym_events, only: event_set, event_t, integrate_events, model_events, EVENT_ANY, &
        EVENT_RISING, EVENT_FALLING
    use holosym_sections, only: section_t, make_section
    use holosym_lyapunov, only: lyapunov_spectrum, lyapunov_result_t, lyapunov_tracker_t
    use holosym_integrator, only: constrained_integrator, step_info_t, step_observer, &
        integrator_stats_t, step_dense_output
    use holosym_observers, only: trajectory_writer, energy_monitor, trajectory_header
    use holosym_rattle, only: rattle_integrator, rattle_stats_t, composition_coefficients, &
        rattle_max_order
    use holosym_task_farm, only: openmp_farm
    use holosym_ensemble, only: ensemble_settings_t, ensemble_states_t, ensemble_result_t, &
        ensemble_sink, run_ensemble, check_ensemble, ensemble_steps, integrate_member, &
        perturbed_states
    use holosym_ensemble_files, only: read_ensemble_states, ensemble_csv_sink
    implicit none
    private

    ! Kinds: working precision (real128, or real64 with -DHOLOSYM_REAL64) and real64.
    public :: wp, dp, wp_is_double
    ! The library's version.
    public :: holosym_version
    ! Status of every fallible procedure, its codes and their names.
    public :: holosym_status_t, status_code_name
    public :: HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, &
        HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, &
        HOLOSYM_OFF_MANIFOLD, HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_INVALID_MODEL, HOLOSYM_INCONSISTENT_SYSTEM, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, HOLOSYM_STEP_TOO_LARGE, &
        HOLOSYM_STEP_TOO_SMALL, HOLOSYM_OUTSIDE_DOMAIN
    ! Basis: quadrature on [0, 1] and Lagrange polynomials.
    public :: gauss_legendre, gauss_lobatto
    public :: lagrange_values, lagrange_derivatives, lagrange_matrices
    ! The problem: the abstract system to extend, its default (difference) Hessians, the
    ! constraint manifold, projection onto it, the paper's models and the catalogue beyond
    ! them (chain and double pendulum, dumbbell on a sphere, charged particle in a magnetic
    ! field, pendulum in a generic potential).
    public :: constrained_hamiltonian, difference_hessian, difference_constraint_hessian
    public :: manifold_residuals, manifold_tolerance_default, full_rank_constraints
    public :: project_to_manifold, projection_report_t, projection_max_iterations_default
    public :: project_tangent, tangent_residual, tangent_tolerance, tangent_basis
    public :: state_from_velocities
    ! A system from formulas: the model file, read, differentiated and compiled.
    public :: formula_model, load_model, model_from_text
    ! A system's procedures and declarations checked against each other.
    public :: check_system, system_check_report_t, check_entry_t
    public :: spherical_pendulum, spring_linkage, planar_pendulum, pendulum_chain
    public :: sphere_dumbbell, magnetic_sphere, generic_pendulum
    ! The Newton settings of an integrator (`integ%newton`).
    public :: newton_settings_t, default_newton_tolerance
    ! Limits of (M, N, G) (HOLOSYM_INVALID_ORDER beyond them; docs/status-codes.md).
    public :: max_order_m, max_order_n, max_gauss_points
    ! The integrator, its per-step diagnostics, observer (with the dense output of the step
    ! just taken) and work counters; the ready-made observers: CSV trajectory writer and
    ! energy/constraint monitor.
    public :: constrained_integrator, step_info_t, step_observer, integrator_stats_t, &
        step_dense_output
    ! The trade of speed for accuracy as one argument: the plan and the integrator set up.
    public :: accuracy_plan_t, init_for_accuracy, accuracy_floor
    ! Events: zero crossings of functions of the motion, located within the steps.
    public :: event_set, event_t, integrate_events, model_events, EVENT_ANY, EVENT_RISING, &
        EVENT_FALLING
    ! Sections: the crossings of a surface g(q, p) = 0 (Poincare sections).
    public :: section_t, make_section
    public :: lyapunov_spectrum, lyapunov_result_t, lyapunov_tracker_t
    public :: trajectory_writer, energy_monitor, trajectory_header
    ! The baseline: RATTLE and its symmetric compositions.
    public :: rattle_integrator, rattle_stats_t, composition_coefficients, rattle_max_order
    ! Ensembles: many trajectories of one system in parallel (OpenMP threads here; MPI
    ! ranks with holosym-mpi), and their CSV files (states in; results written as they
    ! complete, resumable; timing log; samples).
    public :: ensemble_settings_t, ensemble_states_t, ensemble_result_t, ensemble_sink, &
        run_ensemble, check_ensemble, ensemble_steps, integrate_member, perturbed_states
    public :: openmp_farm
    public :: read_ensemble_states, ensemble_csv_sink

end module holosym
