!> category: internal module (use holosym)
!! Newton's method for a square nonlinear system F(x) = 0 in working precision.
!!
!! The system is an object extending `nonlinear_system` (residual and Jacobian). Each
!! iteration equilibrates the rows of the Jacobian, factors it with `lu_factor` and
!! applies the correction. Convergence: the scaled correction, or the remaining error
!! estimated from the contraction rate (theta/(1-theta) |dx|), falls below
!! `settings%tolerance`; or the correction stops decreasing once below
!! `settings%stagnation_level` (the round-off floor of the problem has been reached).
!!
!! Three options make it cheaper without changing the solution (the final iterations
!! always evaluate the residual in working precision, to the same tolerance):
!! - `settings%simplified`: keep the factorised Jacobian across iterations and, with a
!!   `newton_workspace_t`, across solves; refactor at the current iterate when that is
!!   predicted to be cheaper (see `refactor_pays`) or the corrections contract by less
!!   than `settings%contraction_limit` per iteration.
!! - a workspace with `linear_solver = LINEAR_SOLVER_MIXED`: factor the (row-equilibrated)
!!   Jacobian in real64 with LAPACK dgetrf and solve with dgetrs, i.e. iterative refinement
!!   of the real128 residual. A Jacobian that is singular to real64 precision but not to
!!   working precision falls back to the working-precision LU.
!! - `settings%presolve` (with the mixed solver): first iterate the system's
!!   `residual_lowered` (real64 arithmetic, much cheaper than real128) until the
!!   corrections reach about 1.6e-10 (`lowered_tolerance`), then continue with the
!!   working-precision residual.
module holosym_newton
    ! IEEE classification for the finiteness tests: it never raises an exception, and used at
    ! module level it adds no per-call floating-point state handling.
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use holosym_kinds, only: wp, dp, wp_is_double
    use holosym_linalg, only: lu_factor, lu_solve, default_pivot_tolerance, lu_factor_dp, &
        lu_solve_dp, default_pivot_tolerance_dp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NONFINITE_VALUE
    implicit none
    private

    public :: nonlinear_system, newton_settings_t, newton_report_t, newton_solve
    public :: newton_workspace_t, all_finite, all_finite_matrix, stagnation_floor, &
        newton_settings_valid, contraction_limit_of, jacobian_cost_of

    !> Factor the Newton Jacobian in working precision with `lu_factor` (default).
    integer, parameter, public :: LINEAR_SOLVER_NATIVE = 1
    !> Factor it in real64 with LAPACK dgetrf/dgetrs; residuals stay in working precision.
    integer, parameter, public :: LINEAR_SOLVER_MIXED = 2

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> A freshly factorised real64 Jacobian that contracts worse than this is replaced by
    !! a working-precision factorisation (the matrix is too ill-conditioned for real64).
    real(wp), parameter :: mixed_rate_limit = 0.5_wp
    !> ... judged from this iteration on (earlier rates may reflect a far first guess).
    integer, parameter :: mixed_rate_iteration = 3
    !> Simplified Newton: after kept factors proved too stale, later solves refactor at
    !! their first iterate; every this many solves the kept factors are tried again.
    integer, parameter :: retry_reuse_every = 8
    !> Safety factor on the error predicted from the contraction rate (not the plain path).
    real(wp), parameter :: rate_margin = 8
    !> The pre-solve (`settings%presolve`) stops when its corrections reach this size, about
    !! 1.6e-10: well above the real64 round-off of the lowered residual (cond * 1e-16, where
    !! its iterations stagnate and refactor in vain), and close enough that real64 factors
    !! taken there finish in two working-precision residuals (error e -> kappa e^2 +
    !! 1e-16 e); stopping nearer the real64 round-off costs more iterations, stopping
    !! earlier gains nothing. (eps**(5/8) written with square roots, which every compiler
    !! folds in real128.)
    real(wp), parameter :: lowered_tolerance = sqrt(real(epsilon(1.0_dp), wp)) * &
        sqrt(sqrt(sqrt(real(epsilon(1.0_dp), wp))))
    !> ... or stop decreasing below this one (real64 round-off of the lowered residual).
    real(wp), parameter :: lowered_floor = sqrt(real(epsilon(1.0_dp), wp))
    !> Cost of a lowered residual relative to a working-precision one (roughly, on the
    !! example systems), for the refactoring decision of the pre-solve.
    real(wp), parameter :: lowered_cost_ratio = 0.25_wp
    !> This solver's `contraction_limit` when the setting is left at 0: kept dense factors
    !! that contract worse than this per iteration are replaced (a dense factorisation
    !! costs O(n^3): the limit is stricter than the reduced step's banded one).
    real(wp), parameter, public :: dense_contraction_limit = 0.05_wp
    !> This solver's `jacobian_cost` when the setting is left negative: forming and
    !! factoring the dense Newton matrix costs about two working-precision residuals on
    !! the example systems.
    real(wp), parameter, public :: dense_jacobian_cost = 2

    !> A square nonlinear system: extend it and implement `residual` and `jacobian`.
    type, abstract :: nonlinear_system
    contains
        !> F(x); a failure (e.g. a non-finite user value) is returned in `status`.
        procedure(residual_interface), deferred :: residual
        !> F'(x), size(x) x size(x).
        procedure(jacobian_interface), deferred :: jacobian
        !> F(x) to real64 accuracy, cheaper than `residual`, for the pre-solve of
        !! `settings%presolve` (default: `residual` itself).
        procedure :: residual_lowered => default_residual_lowered
        !> F'(x) in real64, for the mixed-precision solver (default: `jacobian`, rounded).
        procedure :: jacobian_lowered => default_jacobian_lowered
    end type nonlinear_system

    !> Knobs of Newton's method; the defaults derive from epsilon(1.0_wp).
    type :: newton_settings_t
        !> Stop when max|dx| <= tolerance * max(scale, max|x|).
        real(wp) :: tolerance = 8 * eps
        !> A correction that no longer decreases is accepted as converged below this level;
        !! <= 0 (the default) means epsilon**(2/3) (not every compiler folds that real128
        !! power in a default value).
        real(wp) :: stagnation_level = 0
        !> Iteration limit.
        integer :: max_iterations = 50
        !> Declared diverged after this many consecutive growing corrections above stagnation.
        integer :: max_growth = 3
        !> Relative pivot threshold of the LU; <= 0 means `default_pivot_tolerance(n)`.
        real(wp) :: pivot_tolerance = 0
        !> Simplified Newton: reuse the factorised Jacobian (across solves too, when a
        !! workspace is given) while the corrections contract well.
        logical :: simplified = .false.
        !> Simplified Newton refactors at the current iterate when a correction is larger
        !! than this fraction of the previous one; 0 (the default) means the solver's own
        !! value (`dense_contraction_limit` 0.05 here, the reduced step's 0.1).
        real(wp) :: contraction_limit = 0
        !> Simplified Newton: cost of a Jacobian and its factorisation, in residual
        !! evaluations; refactoring is chosen when it is predicted to save more than this.
        !! Negative (the default) means the solver's own value (`dense_jacobian_cost` 2
        !! here, the reduced step's 1).
        real(wp) :: jacobian_cost = -1
        !> With the mixed linear solver: iterate `residual_lowered` (real64 arithmetic) to
        !! corrections of about 1.6e-10 before the working-precision residual.
        logical :: presolve = .false.
    end type newton_settings_t

    !> What happened in one Newton solve.
    type :: newton_report_t
        !> Number of iterations (residual evaluations and solves).
        integer :: iterations = 0
        !> Scaled size of the last correction.
        real(wp) :: last_correction = 0
        !> Smallest |pivot| / max|J| of the row-equilibrated Jacobian over the iterations.
        real(wp) :: pivot_ratio = 0
        !> Index of the failing pivot when the Jacobian was singular, else 0.
        integer :: singular_pivot = 0
        !> Jacobian evaluations and LU factorisations of this solve.
        integer :: factorizations = 0
        !> Working-precision residual evaluations of this solve.
        integer :: residual_evaluations = 0
        !> `residual_lowered` evaluations of the pre-solve.
        integer :: lowered_evaluations = 0
        !> True when the solve started with the factors of an earlier solve.
        logical :: reused_factors = .false.
    end type newton_report_t

    !> Preallocated arrays of Newton's method and the factors kept between solves.
    !! Give one to `newton_solve` to avoid allocation and to let simplified Newton reuse
    !! a factorisation across solves. Call `invalidate` when the equations change
    !! substantially (e.g. a new step size).
    type :: newton_workspace_t
        !> LINEAR_SOLVER_NATIVE or LINEAR_SOLVER_MIXED.
        integer :: linear_solver = LINEAR_SOLVER_NATIVE
        !> Size the arrays are allocated for (-1: none).
        integer :: nx = -1
        !> True when `jac`/`jac_dp` hold valid factors.
        logical :: factored = .false.
        !> True when the valid factors are the real64 ones.
        logical :: factors_in_dp = .false.
        !> Pivot ratio of the valid factors.
        real(wp) :: factor_pivot_ratio = 0
        !> Kept factors were too stale last time: refactor at the first iterate.
        logical :: prefer_fresh = .false.
        !> Solves since kept factors were last tried.
        integer :: fresh_streak = 0
        !> Quadratic-convergence constant kappa learnt from fresh factors: a Jacobian taken
        !! at distance e from the solution contracts by about kappa e (0: not known yet).
        real(wp) :: kappa = 0
        real(wp), allocatable :: jac(:, :)     !! Jacobian, then its working-precision factors
        real(wp), allocatable :: rhs(:, :)     !! residual, then the correction (nx x 1)
        real(wp), allocatable :: guess(:)      !! the first guess, restored on failure
        real(wp), allocatable :: row_scale(:)  !! row equilibration of the factors
        real(dp), allocatable :: jac_dp(:, :)  !! real64 factors (mixed precision)
        real(dp), allocatable :: rhs_dp(:, :)  !! real64 right-hand side
        integer, allocatable :: pivots(:)      !! row interchanges
    contains
        !> Allocate for nx unknowns (no-op when already that size).
        procedure :: setup => workspace_setup
        !> Forget the kept factors.
        procedure :: invalidate => workspace_invalidate
        !> Forget everything learnt from earlier solves (factors, kappa, preferences), so
        !! that the next solves depend only on their own inputs.
        procedure :: reset => workspace_reset
    end type newton_workspace_t

    abstract interface
        subroutine residual_interface(self, x, f, status)
            import :: nonlinear_system, wp, holosym_status_t
            class(nonlinear_system), intent(inout) :: self !! the system (may cache)
            real(wp), intent(in) :: x(:)   !! unknowns
            real(wp), intent(out) :: f(:)  !! residual, same size
            type(holosym_status_t), intent(out) :: status !! failure of the evaluation
        end subroutine residual_interface

        subroutine jacobian_interface(self, x, jac, status)
            import :: nonlinear_system, wp, holosym_status_t
            class(nonlinear_system), intent(inout) :: self !! the system (may cache)
            real(wp), intent(in) :: x(:)        !! unknowns
            real(wp), intent(out) :: jac(:, :)  !! dF/dx
            type(holosym_status_t), intent(out) :: status !! failure of the evaluation
        end subroutine jacobian_interface
    end interface

contains

    !> Allocate the workspace for nx unknowns; keeps the factors when the size is unchanged.
    subroutine workspace_setup(self, nx)
        class(newton_workspace_t), intent(inout) :: self
        integer, intent(in) :: nx !! number of unknowns
        if (self%nx == nx) return
        if (allocated(self%jac)) deallocate (self%jac, self%rhs, self%guess, self%row_scale, &
                                             self%jac_dp, self%rhs_dp, self%pivots)
        allocate (self%jac(nx, nx), self%rhs(nx, 1), self%guess(nx), self%row_scale(nx), &
                  self%jac_dp(nx, nx), self%rhs_dp(nx, 1), self%pivots(nx))
        self%nx = nx
        self%factored = .false.
    end subroutine workspace_setup

    !> Forget the kept factors: the next solve starts with a new Jacobian.
    elemental subroutine workspace_invalidate(self)
        class(newton_workspace_t), intent(inout) :: self
        self%factored = .false.
    end subroutine workspace_invalidate

    !> Forget the kept factors and what earlier solves taught (kappa, refactoring habits).
    elemental subroutine workspace_reset(self)
        class(newton_workspace_t), intent(inout) :: self
        self%factored = .false.
        self%kappa = 0
        self%prefer_fresh = .false.
        self%fresh_streak = 0
    end subroutine workspace_reset

    !> Solve F(x) = 0 by Newton's method from the first guess in `x`.
    !!
    !! Codes: HOLOSYM_SINGULAR_MATRIX (a pivot below threshold; `report%singular_pivot`
    !! says which), HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED,
    !! HOLOSYM_NONFINITE_VALUE, HOLOSYM_INVALID_ARGUMENT (max_iterations < 1), or a code
    !! passed on from the system's evaluations. On failure `x` holds the first guess again
    !! and the workspace keeps no factors.
    subroutine newton_solve(system, x, settings, scale, report, status, workspace)
        class(nonlinear_system), intent(inout) :: system !! the equations
        real(wp), intent(inout) :: x(:)                 !! first guess in, solution out
        type(newton_settings_t), intent(in) :: settings !! tolerances and limits
        real(wp), intent(in) :: scale     !! typical magnitude of x (absolute floor of the test)
        type(newton_report_t), intent(out) :: report    !! iterations and diagnostics
        type(holosym_status_t), intent(out), optional :: status !! outcome
        !> Preallocated arrays, linear solver choice and kept factors (default: a fresh
        !! working-precision workspace for this call).
        type(newton_workspace_t), intent(inout), optional :: workspace
        type(newton_workspace_t) :: local

        if (present(workspace)) then
            call solve_core(system, x, settings, scale, report, workspace, status)
        else
            call solve_core(system, x, settings, scale, report, local, status)
        end if
    end subroutine newton_solve

    !> The iteration of `newton_solve` on a given workspace.
    subroutine solve_core(system, x, settings, scale, report, ws, status)
        class(nonlinear_system), intent(inout) :: system
        real(wp), intent(inout) :: x(:)
        type(newton_settings_t), intent(in) :: settings
        real(wp), intent(in) :: scale
        type(newton_report_t), intent(out) :: report
        type(newton_workspace_t), intent(inout) :: ws
        type(holosym_status_t), intent(inout), optional :: status
        real(wp) :: correction, previous, tolerance, pivot_ratio, rate, rate_floor
        real(wp) :: fresh_correction, target, cost, stagnation
        real(dp) :: pivot_ratio_dp
        integer :: info, iter, growth, nx, factor_age, phase_iterations
        logical :: plain, refactor, fresh, native_only, lowered, converged
        type(holosym_status_t) :: eval_status

        nx = size(x)
        if (.not. newton_settings_valid(settings, eval_status%message)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, eval_status%message)
            return
        end if
        ! Finiteness first: an ordered comparison with a NaN raises 'invalid'.
        if (.not. is_finite(scale)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "scale must be >= 0 and " // &
                "finite, got " // real_str(scale))
            return
        else if (scale < 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "scale must be >= 0 and " // &
                "finite, got " // real_str(scale))
            return
        end if
        if (.not. all_finite(x)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "the first guess x contains " // &
                "NaN or Inf")
            return
        end if
        call ws%setup(nx)
        ws%guess = x
        previous = huge(1.0_wp)
        growth = 0
        report%pivot_ratio = huge(1.0_wp)
        tolerance = settings%pivot_tolerance
        if (tolerance <= 0) tolerance = default_pivot_tolerance(nx)
        stagnation = stagnation_floor(settings)
        ! The original full Newton in working precision keeps its exact behaviour.
        plain = .not. settings%simplified .and. ws%linear_solver == LINEAR_SOLVER_NATIVE
        native_only = ws%linear_solver == LINEAR_SOLVER_NATIVE
        refactor = .not. (settings%simplified .and. ws%factored)
        if (.not. refactor .and. ws%prefer_fresh) then
            ! Factors kept from the last solve were too stale then; a Jacobian at the
            ! first iterate saves iterations (retry the kept ones now and then).
            ws%fresh_streak = ws%fresh_streak + 1
            refactor = ws%fresh_streak < retry_reuse_every
            if (.not. refactor) ws%fresh_streak = 0
        end if
        report%reused_factors = .not. refactor
        if (report%reused_factors) report%pivot_ratio = ws%factor_pivot_ratio
        lowered = settings%presolve .and. ws%linear_solver == LINEAR_SOLVER_MIXED .and. &
            .not. wp_is_double
        ! Iterations since the factors in use were computed (0: computed in an earlier solve).
        factor_age = 0
        fresh_correction = 0
        phase_iterations = 0
        do iter = 1, settings%max_iterations
            report%iterations = iter
            if (lowered) then
                report%lowered_evaluations = report%lowered_evaluations + 1
                call system%residual_lowered(x, ws%rhs(:, 1), eval_status)
            else
                report%residual_evaluations = report%residual_evaluations + 1
                call system%residual(x, ws%rhs(:, 1), eval_status)
            end if
            if (.not. eval_status%ok()) then
                call fail(eval_status%code, eval_status%message)
                return
            end if
            fresh = refactor .or. .not. settings%simplified
            if (fresh) then
                if (.not. all_finite(ws%rhs(:, 1))) then
                    call fail(HOLOSYM_NONFINITE_VALUE, "non-finite residual at Newton " // &
                        "iteration " // int_str(iter))
                    return
                end if
                report%factorizations = report%factorizations + 1
                ws%factors_in_dp = .false.
                ! Mixed precision: a real64 Jacobian (assembled in real64 arithmetic by
                ! systems that can), checked, equilibrated and factored in real64.
                if (.not. native_only) then
                    call system%jacobian_lowered(x, ws%jac_dp, eval_status)
                    if (.not. eval_status%ok()) then
                        call fail(eval_status%code, eval_status%message)
                        return
                    end if
                    if (all(ieee_is_finite(ws%jac_dp))) then
                        call equilibrate_rows_dp(ws%jac_dp, ws%row_scale)
                        call lu_factor_dp(ws%jac_dp, ws%pivots, info, &
                            max(real(tolerance, dp), default_pivot_tolerance_dp(nx)), &
                            pivot_ratio_dp)
                        ws%factors_in_dp = info == 0
                        pivot_ratio = real(pivot_ratio_dp, wp)
                    end if
                end if
                ! Working precision: the plain path, or a matrix singular (or not finite)
                ! in real64.
                if (.not. ws%factors_in_dp) then
                    call system%jacobian(x, ws%jac, eval_status)
                    if (.not. eval_status%ok()) then
                        call fail(eval_status%code, eval_status%message)
                        return
                    end if
                    if (.not. all_finite_matrix(ws%jac)) then
                        call fail(HOLOSYM_NONFINITE_VALUE, "non-finite Jacobian at Newton " // &
                            "iteration " // int_str(iter))
                        return
                    end if
                    call equilibrate_rows(ws%jac, ws%row_scale)
                    call lu_factor(ws%jac, ws%pivots, info, tolerance, pivot_ratio)
                end if
                if (info /= 0) then
                    report%singular_pivot = info
                    report%pivot_ratio = 0
                    call fail(HOLOSYM_SINGULAR_MATRIX, "Newton Jacobian singular at pivot " // &
                        int_str(info) // " of " // int_str(nx) // " (relative threshold " // &
                        real_str(tolerance) // ")")
                    return
                end if
                ws%factored = .true.
                ws%factor_pivot_ratio = pivot_ratio
                report%pivot_ratio = min(report%pivot_ratio, pivot_ratio)
                refactor = .false.
            else if (.not. all_finite(ws%rhs(:, 1))) then
                call fail(HOLOSYM_NONFINITE_VALUE, "non-finite residual at Newton iteration " &
                    // int_str(iter))
                return
            end if
            ws%rhs(:, 1) = ws%rhs(:, 1) * ws%row_scale
            if (ws%factors_in_dp) then
                ws%rhs_dp = real(ws%rhs, dp)
                call lu_solve_dp(ws%jac_dp, ws%pivots, ws%rhs_dp)
                ws%rhs = real(ws%rhs_dp, wp)
            else
                call lu_solve(ws%jac, ws%pivots, ws%rhs)
            end if
            x = x - ws%rhs(:, 1)
            correction = maxval(abs(ws%rhs(:, 1))) / max(scale, maxval(abs(x)))
            report%last_correction = correction
            if (.not. is_finite(correction)) then
                call fail(HOLOSYM_NEWTON_DIVERGED, "Newton correction not finite at " // &
                    "iteration " // int_str(iter))
                return
            end if
            ! The pre-solve stops at `lowered_tolerance`; the working-precision phase follows.
            target = settings%tolerance
            if (lowered) target = lowered_tolerance
            ! With contraction rate theta the remaining error is about theta/(1-theta) * dx
            ! (previous = huge at the start of each phase: no rate yet).
            rate = correction / previous
            phase_iterations = phase_iterations + 1
            ! Factors taken at x_k give a first correction ~ |x_k - x*| and then contract
            ! by kappa |x_k - x*|: learn kappa from the second correction.
            if (fresh) then
                factor_age = 1
                fresh_correction = correction
            else if (factor_age > 0) then
                factor_age = factor_age + 1
                if (factor_age == 2 .and. phase_iterations > 1 .and. rate < 1) &
                    ws%kappa = rate / fresh_correction
            end if
            converged = correction <= target
            if (phase_iterations > 1 .and. rate < 1) then
                ! Linear contraction (simplified Newton, real64 factors) varies from one
                ! iteration to the next: trust the predicted error only with a margin.
                if (plain) then
                    converged = converged .or. rate / (1 - rate) * correction <= target
                else
                    converged = converged .or. rate / (1 - rate) * correction <= &
                        target / rate_margin
                end if
            end if
            if (lowered) then
                ! Corrections no longer decreasing at this size: real64 round-off.
                converged = converged .or. (correction >= previous .and. &
                                            correction <= lowered_floor)
            else if (plain .or. fresh .or. phase_iterations > 1) then
                ! Corrections that stop decreasing this small are the round-off floor of the
                ! problem (kept factors contract well above it or are refreshed); so are
                ! fresh factors that no longer contract there.
                converged = converged .or. (correction <= stagnation .and. &
                    (correction >= previous .or. (.not. plain .and. factor_age == 2 .and. &
                                                  rate > mixed_rate_limit)))
            end if
            if (ws%factors_in_dp) then
                rate_floor = real(epsilon(1.0_dp), wp) * nx
            else
                rate_floor = eps * nx
            end if
            if (converged .and. .not. lowered) exit
            if (converged) then
                ! End of the pre-solve: the working-precision phase may start with fresh
                ! factors at this iterate when they are predicted to save residuals there.
                lowered = .false.
                growth = 0
                if (settings%simplified .and. phase_iterations > 1) refactor = refactor .or. &
                    refactor_pays(rate, correction, ws%kappa, rate_floor, settings%tolerance, &
                                  jacobian_cost_of(settings, dense_jacobian_cost))
            else if (plain .or. fresh) then
                if (correction > previous .and. correction > stagnation) then
                    growth = growth + 1
                    if (growth >= settings%max_growth) then
                        call fail(HOLOSYM_NEWTON_DIVERGED, "Newton corrections grew " // &
                            int_str(growth) // " times in a row (last " // &
                            real_str(correction) // ") at iteration " // int_str(iter))
                        return
                    end if
                else
                    growth = 0
                end if
                ! Full Newton: consecutive fresh real64 factorisations that contract poorly
                ! near the solution (where nonlinearity cannot explain it): the matrix is
                ! too ill-conditioned for real64; continue in working precision.
                if (.not. settings%simplified .and. ws%factors_in_dp .and. &
                    iter >= mixed_rate_iteration .and. rate > mixed_rate_limit .and. &
                    previous <= lowered_floor .and. correction > stagnation) &
                    call use_working_precision()
            else if (phase_iterations > 1) then
                if (factor_age == 2 .and. ws%factors_in_dp .and. rate > mixed_rate_limit &
                    .and. fresh_correction <= lowered_floor .and. &
                    correction > stagnation) then
                    ! Fresh real64 factors taken near the solution contract poorly.
                    call use_working_precision()
                else
                    ! Simplified Newton: refactor here when the kept factors contract poorly
                    ! or fresh ones are predicted to need fewer evaluations in all.
                    cost = jacobian_cost_of(settings, dense_jacobian_cost)
                    if (lowered) cost = cost / lowered_cost_ratio
                    refactor = rate > contraction_limit_of(settings, dense_contraction_limit) &
                        .or. refactor_pays(rate, &
                        correction, ws%kappa, rate_floor, target, cost)
                    if (refactor .and. report%reused_factors) ws%prefer_fresh = .true.
                end if
            end if
            if (iter == settings%max_iterations) then
                call fail(HOLOSYM_NEWTON_NOT_CONVERGED, "Newton not converged after " // &
                    int_str(iter) // " iterations (last correction " // real_str(correction) // ")")
                return
            end if
            if (converged) then
                previous = huge(1.0_wp)
                phase_iterations = 0
                cycle
            end if
            previous = correction
        end do
        ! Kept factors that needed no refresh remain the first choice.
        if (report%reused_factors .and. report%factorizations == 0) ws%prefer_fresh = .false.
        call set_status(status, HOLOSYM_SUCCESS, "")

    contains

        !> Continue with working-precision factors (and residuals) from the next iteration.
        subroutine use_working_precision()
            native_only = .true.
            lowered = .false.
            refactor = .true.
        end subroutine use_working_precision

        subroutine fail(code, message)
            integer, intent(in) :: code
            character(len=*), intent(in) :: message
            x = ws%guess
            ws%factored = .false.
            call set_status(status, code, message)
        end subroutine fail

    end subroutine solve_core

    !> The stagnation level a solve uses: `settings%stagnation_level`, or epsilon**(2/3)
    !! when that is <= 0 (the default).
    pure real(wp) function stagnation_floor(settings)
        type(newton_settings_t), intent(in) :: settings !! Newton's settings
        stagnation_floor = settings%stagnation_level
        if (stagnation_floor <= 0) stagnation_floor = eps**(2.0_wp / 3)
    end function stagnation_floor

    !> `settings%contraction_limit`, or `own` (the solver's value) when it is 0.
    pure real(wp) function contraction_limit_of(settings, own) result(limit)
        type(newton_settings_t), intent(in) :: settings !! Newton's settings
        real(wp), intent(in) :: own !! the solver's own limit
        limit = settings%contraction_limit
        if (limit <= 0) limit = own
    end function contraction_limit_of

    !> `settings%jacobian_cost`, or `own` (the solver's value) when it is negative.
    pure real(wp) function jacobian_cost_of(settings, own) result(cost)
        type(newton_settings_t), intent(in) :: settings !! Newton's settings
        real(wp), intent(in) :: own !! the solver's own cost
        cost = settings%jacobian_cost
        if (cost < 0) cost = own
    end function jacobian_cost_of

    !> Whether every Newton setting is in its range; `message` names the first that is not.
    !! Ranges: 1 <= max_iterations, 1 <= max_growth, 0 < tolerance < 1,
    !! 0 <= stagnation_level < 1, pivot_tolerance < 1 (<= 0: the default),
    !! 0 <= contraction_limit < 1 (0: the solver's own), jacobian_cost any (< 0: the
    !! solver's own), every real finite.
    logical function newton_settings_valid(settings, message) result(valid)
        type(newton_settings_t), intent(in) :: settings !! the settings
        character(len=:), allocatable, intent(out) :: message !! the first bad one, or ""
        message = ""
        ! Finiteness first: ordered comparisons with a NaN would raise 'invalid'.
        associate (s => settings)
            if (s%max_iterations < 1) then
                message = "newton%max_iterations must be >= 1, got " // &
                    int_str(s%max_iterations)
            else if (s%max_growth < 1) then
                message = "newton%max_growth must be >= 1, got " // int_str(s%max_growth)
            else if (.not. is_finite(s%tolerance)) then
                message = "newton%tolerance must be finite, got " // real_str(s%tolerance)
            else if (s%tolerance <= 0 .or. s%tolerance >= 1) then
                message = "newton%tolerance must be in (0, 1), got " // real_str(s%tolerance)
            else if (.not. is_finite(s%stagnation_level)) then
                message = "newton%stagnation_level must be finite, got " // &
                    real_str(s%stagnation_level)
            else if (s%stagnation_level < 0 .or. s%stagnation_level >= 1) then
                message = "newton%stagnation_level must be in [0, 1), got " // &
                    real_str(s%stagnation_level)
            else if (.not. is_finite(s%pivot_tolerance)) then
                message = "newton%pivot_tolerance must be finite, got " // &
                    real_str(s%pivot_tolerance)
            else if (s%pivot_tolerance >= 1) then
                message = "newton%pivot_tolerance must be < 1 (<= 0 for the default), got " &
                    // real_str(s%pivot_tolerance)
            else if (.not. is_finite(s%contraction_limit)) then
                message = "newton%contraction_limit must be finite, got " // &
                    real_str(s%contraction_limit)
            else if (s%contraction_limit < 0 .or. s%contraction_limit >= 1) then
                message = "newton%contraction_limit must be in [0, 1) (0: the solver's " // &
                    "own), got " // real_str(s%contraction_limit)
            else if (.not. is_finite(s%jacobian_cost)) then
                message = "newton%jacobian_cost must be finite, got " // &
                    real_str(s%jacobian_cost)
            end if
        end associate
        valid = len(message) == 0
    end function newton_settings_valid

    !> Default `residual_lowered`: the working-precision residual.
    subroutine default_residual_lowered(self, x, f, status)
        class(nonlinear_system), intent(inout) :: self !! the system
        real(wp), intent(in) :: x(:)   !! unknowns
        real(wp), intent(out) :: f(:)  !! residual
        type(holosym_status_t), intent(out) :: status !! failure of the evaluation
        call self%residual(x, f, status)
    end subroutine default_residual_lowered

    !> Default `jacobian_lowered`: the working-precision Jacobian, rounded to real64.
    subroutine default_jacobian_lowered(self, x, jac, status)
        class(nonlinear_system), intent(inout) :: self !! the system
        real(wp), intent(in) :: x(:)        !! unknowns
        real(dp), intent(out) :: jac(:, :)  !! dF/dx in real64
        type(holosym_status_t), intent(out) :: status !! failure of the evaluation
        real(wp), allocatable :: full(:, :)
        allocate (full(size(x), size(x)))
        call self%jacobian(x, full, status)
        jac = real(full, dp)
    end subroutine default_jacobian_lowered

    !> Scale each row of a working-precision matrix by a power of two so that its largest
    !! entry lies in [1, 2): the pivot test then does not depend on the equations' units,
    !! and the scaling is exact (zero rows keep scale 1).
    pure subroutine equilibrate_rows(a, row_scale)
        real(wp), intent(inout) :: a(:, :)       !! matrix, scaled in place
        real(wp), intent(out) :: row_scale(:)   !! scale of each row
        real(wp) :: row_max
        integer :: i
        do i = 1, size(a, 1)
            row_max = maxval(abs(a(i, :)))
            if (row_max > 0) then
                row_scale(i) = set_exponent(1.0_wp, 1 - exponent(row_max))
                a(i, :) = a(i, :) * row_scale(i)
            else
                row_scale(i) = 1
            end if
        end do
    end subroutine equilibrate_rows

    !> Scale each row of a real64 matrix by a power of two so that its largest entry lies
    !! in [1, 2) (exact; zero rows keep scale 1); the scales are returned in working precision.
    pure subroutine equilibrate_rows_dp(a, row_scale)
        real(dp), intent(inout) :: a(:, :)       !! matrix, scaled in place
        real(wp), intent(out) :: row_scale(:)   !! scale of each row
        real(dp) :: row_max
        integer :: i
        do i = 1, size(a, 1)
            row_max = maxval(abs(a(i, :)))
            if (row_max > 0) then
                row_scale(i) = set_exponent(1.0_wp, 1 - exponent(row_max))
                a(i, :) = a(i, :) * real(row_scale(i), dp)
            else
                row_scale(i) = 1
            end if
        end do
    end subroutine equilibrate_rows_dp

    !> Whether simplified Newton should refactor at the current iterate. With factors
    !! contracting by `rate`, the error left after a correction of size `correction` is
    !! e = rate/(1-rate) correction and reaching `tolerance` takes log(tolerance/e)/log(rate)
    !! more residuals; fresh factors at this iterate would contract by about
    !! max(kappa e, rate_floor) for the price of `jacobian_cost` residuals.
    pure logical function refactor_pays(rate, correction, kappa, rate_floor, tolerance, &
                                        jacobian_cost)
        real(wp), intent(in) :: rate          !! contraction of the kept factors, > 0
        real(wp), intent(in) :: correction    !! size of the last correction
        real(wp), intent(in) :: kappa         !! quadratic-convergence constant (0: unknown)
        real(wp), intent(in) :: rate_floor    !! best contraction the linear solver allows
        real(wp), intent(in) :: tolerance     !! convergence tolerance on the correction
        real(wp), intent(in) :: jacobian_cost !! Jacobian + factorisation, in residuals
        real(wp) :: remaining, fresh_rate
        refactor_pays = .false.
        if (kappa <= 0 .or. rate <= 0 .or. rate >= 1) return
        remaining = rate / (1 - rate) * correction
        if (remaining <= tolerance) return
        fresh_rate = max(kappa * remaining, rate_floor)
        if (fresh_rate >= rate) return
        ! Iteration counts need no working-precision logarithms (slow in real128).
        refactor_pays = jacobian_cost + log(real(tolerance / remaining, dp)) &
            / log(real(fresh_rate, dp)) < log(real(tolerance / remaining, dp)) &
            / log(real(rate, dp))
    end function refactor_pays

    !> True when no entry is NaN or infinite (never raises an IEEE exception).
    pure logical function all_finite(values)
        real(wp), intent(in) :: values(:) !! values to test
        integer :: i
        all_finite = .true.
        do i = 1, size(values)
            if (.not. ieee_is_finite(values(i))) then
                all_finite = .false.
                return
            end if
        end do
    end function all_finite

    !> `all_finite` for a matrix.
    pure logical function all_finite_matrix(values)
        real(wp), intent(in) :: values(:, :) !! values to test
        integer :: j
        all_finite_matrix = .true.
        do j = 1, size(values, 2)
            if (.not. all_finite(values(:, j))) then
                all_finite_matrix = .false.
                return
            end if
        end do
    end function all_finite_matrix

end module holosym_newton
