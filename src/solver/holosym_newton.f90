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
!!   corrections reach about 1.6e-10 (`presolve_tolerance`), then continue with the
!!   working-precision residual.
!!
!! Every decision of the iteration (converged, stagnated, diverging, refactor) and every
!! constant behind it is in `holosym_newton_policy`, shared with `kept_newton_solve`.
module holosym_newton
    ! IEEE classification for the finiteness tests: it never raises an exception, and used at
    ! module level it adds no per-call floating-point state handling.
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_positive_inf
    use holosym_kinds, only: wp, dp, wp_is_double
    use holosym_float_bits, only: all_below_exponent
    use holosym_factors, only: real64_factors_t
    use holosym_linalg, only: lu_factor, lu_solve, default_pivot_tolerance, lu_factor_dp, &
        lu_solve_dp, default_pivot_tolerance_dp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NONFINITE_VALUE
    use holosym_newton_policy, only: predicted_within, stagnated, growth_after, refactor_pays, &
        rate_margin, retry_kept_every, dense_contraction_limit, dense_jacobian_cost, &
        lowered_cost_ratio, presolve_tolerance, presolve_floor, mixed_rate_limit, &
        mixed_rate_iteration
    implicit none
    private

    public :: nonlinear_system, newton_settings_t, newton_report_t, newton_solve
    public :: newton_workspace_t, all_finite, all_finite_matrix, fits_real64, stagnation_floor, &
        newton_settings_valid, contraction_limit_of, jacobian_cost_of

    !> Factor the Newton Jacobian in working precision with `lu_factor` (default).
    integer, parameter, public :: LINEAR_SOLVER_NATIVE = 1
    !> Factor it in real64 with LAPACK dgetrf/dgetrs; residuals stay in working precision.
    integer, parameter, public :: LINEAR_SOLVER_MIXED = 2

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> The default tolerance on Newton's corrections: 8 epsilon of the iterate, corrections
    !! at the round-off of the residual's evaluation (a looser tolerance leaves errors of
    !! its size in the solution).
    real(wp), parameter, public :: default_newton_tolerance = 8 * eps

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
        !> F(x) with real64 arguments and results, for the real64 phase of
        !! `kept_newton_solve` (default: `residual_lowered`, converted).
        procedure :: residual_dp => default_residual_dp
        !> The Newton matrix at x, the point of the last evaluation (`residual_dp` when
        !! `lowered`, else `residual`), formed in real64 and factored into `factors`, for
        !! `kept_newton_solve`; `info` > 0 names a pivot below `pivot_tolerance` (default:
        !! `jacobian_lowered`, factored dense). Systems with a sparse or banded Newton
        !! matrix form it in their pattern from what the evaluation left behind.
        procedure :: factor_matrix => default_factor_matrix
        !> An approximation of the Newton matrix that is much cheaper to form, factor and
        !! solve with, at x (the point of the last evaluation, as for `factor_matrix`),
        !! for the iteration without the Newton matrix of `kept_newton_solve` (the
        !! contraction it achieves decides whether it is used); `info` < 0: the system
        !! has none (the default), > 0: it is singular.
        procedure :: factor_approximate => default_factor_approximate
        !> Replace a residual (real64) by the correction of the approximate matrix last
        !! formed by `factor_approximate` (default: unchanged; never called then).
        procedure :: solve_approximate => default_solve_approximate
    end type nonlinear_system

    !> Knobs of Newton's method; the defaults derive from epsilon(1.0_wp).
    type :: newton_settings_t
        !> Stop when max|dx| <= tolerance * max(scale, max|x|).
        real(wp) :: tolerance = default_newton_tolerance
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
        !! value (`dense_contraction_limit` 0.05 here, `banded_contraction_limit` 0.1 in the
        !! reduced step; `holosym_newton_policy`). The reduced step's iteration without the
        !! Newton matrix gives way to the Newton matrix beyond the same value when one is
        !! given (`approximate_contraction_limit` 0.1 otherwise).
        real(wp) :: contraction_limit = 0
        !> Simplified Newton: cost of a Jacobian and its factorisation, in residual
        !! evaluations; refactoring is chosen when it is predicted to save more than this.
        !! Negative (the default) means the solver's own value (`dense_jacobian_cost` 2
        !! here, `banded_jacobian_cost` 1 in the reduced step).
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

    !> The state of one `newton_solve` between its decisions.
    type :: iteration_t
        real(wp) :: pivot_tolerance = 0      ! relative pivot threshold of the LU
        real(wp) :: stagnation = 0           ! round-off floor of the corrections
        real(wp) :: previous = huge(1.0_wp)  ! last correction of this phase (huge: none)
        real(wp) :: rate = 1                 ! last correction / the one before
        real(wp) :: target = 0               ! the phase's tolerance on the corrections
        real(wp) :: fresh_correction = 0     ! first correction of the factors in use
        integer :: growth = 0                ! consecutive growing corrections
        integer :: factor_age = 0            ! iterations of the factors in use (0: older)
        integer :: phase_iterations = 0      ! iterations of this phase
        logical :: plain = .false.           ! full Newton, working-precision LU
        logical :: native_only = .false.     ! working-precision factors only
        logical :: lowered = .false.         ! in the real64 pre-solve
        logical :: refactor = .false.        ! factor at the next iterate
    end type iteration_t

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

    !> The iteration of `newton_solve` on a given workspace: a loop of evaluations,
    !! factorisations and corrections, and after each correction the decisions of
    !! `holosym_newton_policy` (`converged`, `after_correction`).
    subroutine solve_core(system, x, settings, scale, report, ws, status)
        class(nonlinear_system), intent(inout) :: system
        real(wp), intent(inout) :: x(:)
        type(newton_settings_t), intent(in) :: settings
        real(wp), intent(in) :: scale
        type(newton_report_t), intent(out) :: report
        type(newton_workspace_t), intent(inout) :: ws
        type(holosym_status_t), intent(inout), optional :: status
        type(iteration_t) :: it
        type(holosym_status_t) :: local
        real(wp) :: correction
        integer :: iter
        logical :: fresh, converged

        if (.not. inputs_valid(settings, scale, x, status)) return
        call ws%setup(size(x))
        ws%guess = x
        call start_iteration(settings, ws, it, report)
        do iter = 1, settings%max_iterations
            report%iterations = iter
            if (it%lowered) then
                report%lowered_evaluations = report%lowered_evaluations + 1
                call system%residual_lowered(x, ws%rhs(:, 1), local)
            else
                report%residual_evaluations = report%residual_evaluations + 1
                call system%residual(x, ws%rhs(:, 1), local)
            end if
            if (local%ok() .and. .not. all_finite(ws%rhs(:, 1))) call set_status(local, &
                HOLOSYM_NONFINITE_VALUE, "non-finite residual at Newton iteration " // &
                int_str(iter))
            fresh = it%refactor .or. .not. settings%simplified
            if (local%ok() .and. fresh) call factor_at(system, x, ws, it, iter, report, local)
            if (.not. local%ok()) then
                call fail(local%code, local%message)
                return
            end if
            correction = newton_correction(ws, x, scale)
            report%last_correction = correction
            if (.not. is_finite(correction)) then
                call fail(HOLOSYM_NEWTON_DIVERGED, "Newton correction not finite at " // &
                    "iteration " // int_str(iter))
                return
            end if
            converged = phase_converged(it, settings, ws, fresh, correction)
            if (converged .and. .not. it%lowered) exit
            call after_correction(it, settings, ws, report, fresh, converged, correction)
            if (it%growth >= settings%max_growth) then
                call fail(HOLOSYM_NEWTON_DIVERGED, "Newton corrections grew " // &
                    int_str(it%growth) // " times in a row (last " // &
                    real_str(correction) // ") at iteration " // int_str(iter))
                return
            end if
            if (iter == settings%max_iterations) then
                call fail(HOLOSYM_NEWTON_NOT_CONVERGED, "Newton not converged after " // &
                    int_str(iter) // " iterations (last correction " // real_str(correction) // ")")
                return
            end if
        end do
        ! Kept factors that needed no refresh remain the first choice.
        if (report%reused_factors .and. report%factorizations == 0) ws%prefer_fresh = .false.
        call set_status(status, HOLOSYM_SUCCESS, "")

    contains

        subroutine fail(code, message)
            integer, intent(in) :: code
            character(len=*), intent(in) :: message
            x = ws%guess
            ws%factored = .false.
            call set_status(status, code, message)
        end subroutine fail

    end subroutine solve_core

    !> Whether the settings, the scale and the first guess of a solve are valid; else
    !! HOLOSYM_INVALID_ARGUMENT naming the first that is not.
    logical function inputs_valid(settings, scale, x, status) result(valid)
        type(newton_settings_t), intent(in) :: settings
        real(wp), intent(in) :: scale, x(:)
        type(holosym_status_t), intent(inout), optional :: status
        character(len=:), allocatable :: message
        valid = .false.
        if (.not. newton_settings_valid(settings, message)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, message)
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
        valid = .true.
    end function inputs_valid

    !> The state of a solve before its first iteration: its path (`plain`, mixed, pre-solve)
    !! and whether it starts with the kept factors of an earlier solve.
    subroutine start_iteration(settings, ws, it, report)
        type(newton_settings_t), intent(in) :: settings
        type(newton_workspace_t), intent(inout) :: ws
        type(iteration_t), intent(out) :: it
        type(newton_report_t), intent(inout) :: report
        integer :: nx
        nx = size(ws%guess)
        it%pivot_tolerance = settings%pivot_tolerance
        if (it%pivot_tolerance <= 0) it%pivot_tolerance = default_pivot_tolerance(nx)
        it%stagnation = stagnation_floor(settings)
        ! The original full Newton in working precision keeps its exact behaviour.
        it%plain = .not. settings%simplified .and. ws%linear_solver == LINEAR_SOLVER_NATIVE
        it%native_only = ws%linear_solver == LINEAR_SOLVER_NATIVE
        it%refactor = .not. (settings%simplified .and. ws%factored)
        if (.not. it%refactor .and. ws%prefer_fresh) then
            ! Factors kept from the last solve were too stale then; a Jacobian at the
            ! first iterate saves iterations (retry the kept ones now and then).
            ws%fresh_streak = ws%fresh_streak + 1
            it%refactor = ws%fresh_streak < retry_kept_every
            if (.not. it%refactor) ws%fresh_streak = 0
        end if
        report%pivot_ratio = huge(1.0_wp)
        report%reused_factors = .not. it%refactor
        if (report%reused_factors) report%pivot_ratio = ws%factor_pivot_ratio
        it%lowered = settings%presolve .and. ws%linear_solver == LINEAR_SOLVER_MIXED .and. &
            .not. wp_is_double
    end subroutine start_iteration

    !> Form and factor the Newton matrix at x (the residual just evaluated there): in real64
    !! (mixed precision) unless singular or not finite there, else in working precision.
    !! HOLOSYM_SINGULAR_MATRIX (`report%singular_pivot`), or the code of an evaluation.
    subroutine factor_at(system, x, ws, it, iter, report, status)
        class(nonlinear_system), intent(inout) :: system
        real(wp), intent(in) :: x(:)
        type(newton_workspace_t), intent(inout) :: ws
        type(iteration_t), intent(inout) :: it
        integer, intent(in) :: iter
        type(newton_report_t), intent(inout) :: report
        type(holosym_status_t), intent(inout) :: status
        real(wp) :: pivot_ratio
        real(dp) :: pivot_ratio_dp
        integer :: info, nx
        nx = size(x)
        report%factorizations = report%factorizations + 1
        ws%factors_in_dp = .false.
        info = 0
        ! Mixed precision: a real64 Jacobian (assembled in real64 arithmetic by systems that
        ! can), checked, equilibrated and factored in real64.
        if (.not. it%native_only) then
            call system%jacobian_lowered(x, ws%jac_dp, status)
            if (.not. status%ok()) return
            if (all(ieee_is_finite(ws%jac_dp))) then
                call equilibrate_rows_dp(ws%jac_dp, ws%row_scale)
                call lu_factor_dp(ws%jac_dp, ws%pivots, info, &
                    max(real(it%pivot_tolerance, dp), default_pivot_tolerance_dp(nx)), &
                    pivot_ratio_dp)
                ws%factors_in_dp = info == 0
                pivot_ratio = real(pivot_ratio_dp, wp)
            end if
        end if
        ! Working precision: the plain path, or a matrix singular (or not finite) in real64.
        if (.not. ws%factors_in_dp) then
            call system%jacobian(x, ws%jac, status)
            if (.not. status%ok()) return
            if (.not. all_finite_matrix(ws%jac)) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "non-finite Jacobian at " // &
                    "Newton iteration " // int_str(iter))
                return
            end if
            call equilibrate_rows(ws%jac, ws%row_scale)
            call lu_factor(ws%jac, ws%pivots, info, it%pivot_tolerance, pivot_ratio)
        end if
        if (info /= 0) then
            report%singular_pivot = info
            report%pivot_ratio = 0
            call set_status(status, HOLOSYM_SINGULAR_MATRIX, "Newton Jacobian singular at " // &
                "pivot " // int_str(info) // " of " // int_str(nx) // " (relative " // &
                "threshold " // real_str(it%pivot_tolerance) // ")")
            return
        end if
        ws%factored = .true.
        ws%factor_pivot_ratio = pivot_ratio
        report%pivot_ratio = min(report%pivot_ratio, pivot_ratio)
        it%refactor = .false.
    end subroutine factor_at

    !> Whether every finite entry of `values` is below 2^1023 in magnitude, so that
    !! converting it to real64 cannot overflow (NaN and Inf convert as they are). Read from
    !! the exponent bits (`all_below_exponent`): no real128 comparison per entry.
    pure logical function fits_real64(values) result(fits)
        real(wp), intent(in) :: values(:)
        fits = all_below_exponent(values, size(values), maxexponent(1.0_dp) - 1)
    end function fits_real64

    !> Apply the Newton correction for the residual in ws%rhs to x; its size relative to
    !! max(scale, max|x|). A residual beyond the range of real64 cannot be solved with
    !! real64 factors: the correction is then +Inf (the iteration has diverged) and x is
    !! left as it is.
    real(wp) function newton_correction(ws, x, scale) result(correction)
        type(newton_workspace_t), intent(inout) :: ws
        real(wp), intent(inout) :: x(:)
        real(wp), intent(in) :: scale
        ws%rhs(:, 1) = ws%rhs(:, 1) * ws%row_scale
        if (ws%factors_in_dp .and. .not. fits_real64(ws%rhs(:, 1))) then
            correction = ieee_value(correction, ieee_positive_inf)
            return
        end if
        if (ws%factors_in_dp) then
            ws%rhs_dp = real(ws%rhs, dp)
            call lu_solve_dp(ws%jac_dp, ws%pivots, ws%rhs_dp)
            ws%rhs = real(ws%rhs_dp, wp)
        else
            call lu_solve(ws%jac, ws%pivots, ws%rhs)
        end if
        x = x - ws%rhs(:, 1)
        correction = maxval(abs(ws%rhs(:, 1))) / max(scale, maxval(abs(x)))
    end function newton_correction

    !> After a correction `correction` (`fresh`: with factors formed at this iterate):
    !! the rate, what the workspace learns (kappa) and whether the phase (pre-solve, or the
    !! working-precision iteration) has converged: the correction, or the error predicted
    !! from the rate, within the phase's target; or round-off stagnation.
    logical function phase_converged(it, settings, ws, fresh, correction) result(converged)
        type(iteration_t), intent(inout) :: it
        type(newton_settings_t), intent(in) :: settings
        type(newton_workspace_t), intent(inout) :: ws
        logical, intent(in) :: fresh
        real(wp), intent(in) :: correction
        real(wp) :: margin
        ! The pre-solve stops at `presolve_tolerance`; the working-precision phase follows.
        it%target = settings%tolerance
        if (it%lowered) it%target = presolve_tolerance
        ! previous = huge at the start of each phase: no rate yet.
        it%rate = correction / it%previous
        it%phase_iterations = it%phase_iterations + 1
        ! Factors taken at x_k give a first correction ~ |x_k - x*| and then contract by
        ! kappa |x_k - x*|: learn kappa from the second correction.
        if (fresh) then
            it%factor_age = 1
            it%fresh_correction = correction
        else if (it%factor_age > 0) then
            it%factor_age = it%factor_age + 1
            if (it%factor_age == 2 .and. it%phase_iterations > 1 .and. it%rate < 1) &
                ws%kappa = it%rate / it%fresh_correction
        end if
        converged = correction <= it%target
        if (it%phase_iterations > 1) then
            ! Linear contraction (simplified Newton, real64 factors) varies from one
            ! iteration to the next: trust the predicted error only with a margin.
            margin = rate_margin
            if (it%plain) margin = 1
            converged = converged .or. predicted_within(it%rate, correction, it%target, margin)
        end if
        if (it%lowered) then
            ! Corrections no longer decreasing at this size: real64 round-off.
            converged = converged .or. stagnated(it%rate, correction, presolve_floor, 1.0_wp)
        else if (it%plain .or. fresh .or. it%phase_iterations > 1) then
            ! Corrections that stop decreasing this small are the round-off floor of the
            ! problem (kept factors contract well above it or are refreshed); so are fresh
            ! factors that no longer contract there.
            converged = converged .or. stagnated(it%rate, correction, it%stagnation, 1.0_wp) &
                .or. (.not. it%plain .and. it%factor_age == 2 .and. &
                      stagnated(it%rate, correction, it%stagnation, mixed_rate_limit))
        end if
    end function phase_converged

    !> The decisions after a correction that did not end the solve: at the end of the
    !! pre-solve, whether fresh factors pay for the working-precision phase; else the count
    !! of growing corrections (divergence), a switch to working-precision factors where
    !! real64 ones contract poorly near the solution, and (simplified Newton) whether to
    !! refactor at the next iterate.
    subroutine after_correction(it, settings, ws, report, fresh, converged, correction)
        type(iteration_t), intent(inout) :: it
        type(newton_settings_t), intent(in) :: settings
        type(newton_workspace_t), intent(inout) :: ws
        type(newton_report_t), intent(in) :: report
        logical, intent(in) :: fresh, converged
        real(wp), intent(in) :: correction
        real(wp) :: rate_floor, cost
        rate_floor = eps * size(ws%guess)
        if (ws%factors_in_dp) rate_floor = real(epsilon(1.0_dp), wp) * size(ws%guess)
        cost = jacobian_cost_of(settings, dense_jacobian_cost)
        if (converged) then
            ! End of the pre-solve: the working-precision phase may start with fresh factors
            ! at this iterate when they are predicted to save residuals there.
            it%lowered = .false.
            it%growth = 0
            if (settings%simplified .and. it%phase_iterations > 1) it%refactor = it%refactor &
                .or. refactor_pays(it%rate, correction, ws%kappa, rate_floor, &
                                   settings%tolerance, cost)
            it%previous = huge(1.0_wp)
            it%phase_iterations = 0
            return
        end if
        if (it%plain .or. fresh) then
            if (correction > it%stagnation) then
                it%growth = growth_after(it%rate, it%growth, .false.)
            else
                it%growth = 0
            end if
            ! Full Newton: consecutive fresh real64 factorisations that contract poorly near
            ! the solution (where nonlinearity cannot explain it): the matrix is too
            ! ill-conditioned for real64; continue in working precision.
            if (.not. settings%simplified .and. ws%factors_in_dp .and. &
                report%iterations >= mixed_rate_iteration .and. it%rate > mixed_rate_limit &
                .and. it%previous <= presolve_floor .and. correction > it%stagnation) &
                call use_working_precision(it)
        else if (it%phase_iterations > 1) then
            if (it%factor_age == 2 .and. ws%factors_in_dp .and. it%rate > mixed_rate_limit &
                .and. it%fresh_correction <= presolve_floor .and. &
                correction > it%stagnation) then
                ! Fresh real64 factors taken near the solution contract poorly.
                call use_working_precision(it)
            else
                ! Simplified Newton: refactor here when the kept factors contract poorly or
                ! fresh ones are predicted to need fewer evaluations in all.
                if (it%lowered) cost = cost / lowered_cost_ratio
                it%refactor = it%rate > contraction_limit_of(settings, dense_contraction_limit) &
                    .or. refactor_pays(it%rate, correction, ws%kappa, rate_floor, it%target, &
                                       cost)
                if (it%refactor .and. report%reused_factors) ws%prefer_fresh = .true.
            end if
        end if
        it%previous = correction
    end subroutine after_correction

    !> Continue with working-precision factors (and residuals) from the next iteration.
    pure subroutine use_working_precision(it)
        type(iteration_t), intent(inout) :: it
        it%native_only = .true.
        it%lowered = .false.
        it%refactor = .true.
    end subroutine use_working_precision

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

    !> Default `residual_dp`: `residual_lowered` at x in working precision, rounded.
    subroutine default_residual_dp(self, x, f, status)
        class(nonlinear_system), intent(inout) :: self !! the system
        real(dp), intent(in) :: x(:)   !! unknowns
        real(dp), intent(out) :: f(:)  !! residual
        type(holosym_status_t), intent(out) :: status !! failure of the evaluation
        real(wp) :: f_wp(size(f))
        call self%residual_lowered(real(x, wp), f_wp, status)
        f = real(f_wp, dp)
    end subroutine default_residual_dp

    !> Default `factor_matrix`: `jacobian_lowered` at x, factored as a dense matrix (the
    !! factors must be set up dense, e.g. with bandwidths n - 1).
    subroutine default_factor_matrix(self, x, lowered, factors, pivot_tolerance, info, status)
        class(nonlinear_system), intent(inout) :: self !! the system
        real(wp), intent(in) :: x(:)         !! the point of the last evaluation
        logical, intent(in) :: lowered       !! that evaluation was `residual_dp`
        type(real64_factors_t), intent(inout) :: factors !! set up for size(x), dense
        real(dp), intent(in) :: pivot_tolerance !! relative pivot threshold (<= 0: default)
        integer, intent(out) :: info         !! 0, or the singular pivot
        type(holosym_status_t), intent(out) :: status !! failure of the evaluation
        real(dp), allocatable :: jac(:, :)
        if (lowered) continue
        info = 0
        allocate (jac(size(x), size(x)))
        call self%jacobian_lowered(x, jac, status)
        if (.not. status%ok()) return
        if (.not. all(ieee_is_finite(jac))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "non-finite Newton matrix")
            return
        end if
        call factors%factor_dense(jac, info, pivot_tolerance)
    end subroutine default_factor_matrix

    !> No approximate Newton matrix (`info` = -1).
    subroutine default_factor_approximate(self, x, lowered, info, status)
        class(nonlinear_system), intent(inout) :: self !! the system
        real(wp), intent(in) :: x(:)         !! the point of the last evaluation
        logical, intent(in) :: lowered       !! that evaluation was `residual_dp`
        integer, intent(out) :: info         !! -1: none
        type(holosym_status_t), intent(out) :: status !! success
        if (lowered .or. size(x) < 0) continue
        info = -1
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine default_factor_approximate

    !> No approximate Newton matrix: the residual is left as it is.
    subroutine default_solve_approximate(self, f)
        class(nonlinear_system), intent(inout) :: self !! the system
        real(dp), intent(inout) :: f(:)      !! residual in, correction out
        if (size(f) < 0) continue
    end subroutine default_solve_approximate

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
