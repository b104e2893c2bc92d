!> The internals of holosym under one name, for tests, the `holosym` command and expert
!! users: no stability promise, any of them may change in any release. The public API is
!! [[holosym]]; everything here is also reachable through the module that defines it.
!!
!! - [[lu_factor]], [[lu_solve]], [[default_pivot_tolerance]]: LU factorisation with
!!   partial pivoting in working precision; [[lu_factor_dp]], [[lu_solve_dp]],
!!   [[default_pivot_tolerance_dp]]: the same in real64 through LAPACK.
!! - [[nonlinear_system]], [[newton_solve]], [[newton_report_t]], [[newton_workspace_t]],
!!   `LINEAR_SOLVER_NATIVE`, `LINEAR_SOLVER_MIXED`: Newton's method on any square system,
!!   what one solve did, its work arrays and the linear solvers it factors with;
!!   [[kept_newton_solve]], [[kept_newton_t]], [[kept_report_t]]: simplified Newton on
!!   real64 factors (dense or banded) kept across solves, the reduced step's iteration.
!! - [[discrete_scheme]], [[scheme_counters_t]], [[unknown_count]]: the general scheme's
!!   equations of one step and their size for (M, N, G, n, m); `JACOBIAN_ASSEMBLED`,
!!   `JACOBIAN_RESIDUAL_DIFFERENCES`, `HESSIANS_USER`, `HESSIANS_DIFFERENCES`: its modes
!!   (the integrator sets them from its `jacobian` and `hessians` settings).
!! - [[farm_job]], [[task_farm]], [[record_reader_t]], `put`: the task farm under the
!!   ensemble (a job's tasks on workers, results to one collector, packed as records), for
!!   parallel drivers of one's own.
!! - [[result_header]], [[result_row]], [[samples_header]]: the lines of an ensemble's
!!   CSV files.
module holosym_internal
    use holosym_linalg, only: lu_factor, lu_solve, default_pivot_tolerance, lu_factor_dp, &
        lu_solve_dp, default_pivot_tolerance_dp
    use holosym_newton, only: nonlinear_system, newton_solve, newton_report_t, &
        newton_workspace_t, LINEAR_SOLVER_NATIVE, LINEAR_SOLVER_MIXED
    use holosym_kept_newton, only: kept_newton_solve, kept_newton_t, kept_report_t
    use holosym_scheme, only: discrete_scheme, scheme_counters_t, unknown_count, &
        JACOBIAN_ASSEMBLED, JACOBIAN_RESIDUAL_DIFFERENCES, HESSIANS_USER, HESSIANS_DIFFERENCES
    use holosym_task_farm, only: farm_job, task_farm
    use holosym_records, only: record_reader_t, put
    use holosym_ensemble_files, only: result_header, result_row, samples_header
    implicit none
    private

    ! Dense LU: working precision, and real64 through LAPACK.
    public :: lu_factor, lu_solve, default_pivot_tolerance
    public :: lu_factor_dp, lu_solve_dp, default_pivot_tolerance_dp
    ! Newton's method on any `nonlinear_system`.
    public :: nonlinear_system, newton_solve, newton_report_t, newton_workspace_t, &
        LINEAR_SOLVER_NATIVE, LINEAR_SOLVER_MIXED
    public :: kept_newton_solve, kept_newton_t, kept_report_t
    ! The discrete equations of one step, with the modes of its Jacobian and Hessians
    ! (`discrete_scheme%jacobian_mode`, `%hessian_mode`).
    public :: discrete_scheme, scheme_counters_t, unknown_count
    public :: JACOBIAN_ASSEMBLED, JACOBIAN_RESIDUAL_DIFFERENCES, HESSIANS_USER, &
        HESSIANS_DIFFERENCES
    ! The task farm under the ensemble and the records in which tasks return results.
    public :: farm_job, task_farm, record_reader_t, put
    ! The lines of an ensemble's CSV files.
    public :: result_header, result_row, samples_header

end module holosym_internal
