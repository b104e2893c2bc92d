!> Newton's method for a square nonlinear system F(x) = 0 in working precision.
!!
!! The system is an object extending `nonlinear_system` (residual and Jacobian). Each
!! iteration equilibrates the rows of the Jacobian, factors it with `lu_factor` and
!! applies the correction. Convergence: the scaled correction, or the remaining error
!! estimated from the contraction rate (theta/(1-theta) |dx|), falls below
!! `settings%tolerance`; or the correction stops decreasing once below
!! `settings%stagnation_level` (the round-off floor of the problem has been reached).
module holosym_newton
    use holosym_kinds, only: wp
    use holosym_linalg, only: lu_factor, lu_solve, default_pivot_tolerance
    use holosym_status, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NONFINITE_VALUE
    implicit none
    private

    public :: nonlinear_system, newton_settings_t, newton_report_t, newton_solve

    real(wp), parameter :: eps = epsilon(1.0_wp)

    !> A square nonlinear system: extend it and implement `residual` and `jacobian`.
    type, abstract :: nonlinear_system
    contains
        !> F(x); a failure (e.g. a non-finite user value) is returned in `status`.
        procedure(residual_interface), deferred :: residual
        !> F'(x), size(x) x size(x).
        procedure(jacobian_interface), deferred :: jacobian
    end type nonlinear_system

    !> Knobs of Newton's method; the defaults derive from epsilon(1.0_wp).
    type :: newton_settings_t
        !> Stop when max|dx| <= tolerance * max(scale, max|x|).
        real(wp) :: tolerance = 8 * eps
        !> A correction that no longer decreases is accepted as converged below this level.
        real(wp) :: stagnation_level = eps**(2.0_wp / 3)
        !> Iteration limit.
        integer :: max_iterations = 50
        !> Declared diverged after this many consecutive growing corrections above stagnation.
        integer :: max_growth = 3
        !> Relative pivot threshold of the LU; <= 0 means `default_pivot_tolerance(n)`.
        real(wp) :: pivot_tolerance = 0
    end type newton_settings_t

    !> What happened in one Newton solve.
    type :: newton_report_t
        !> Number of iterations (= Jacobian factorisations and solves).
        integer :: iterations = 0
        !> Scaled size of the last correction.
        real(wp) :: last_correction = 0
        !> Smallest |pivot| / max|J| of the row-equilibrated Jacobian over the iterations.
        real(wp) :: pivot_ratio = 0
        !> Index of the failing pivot when the Jacobian was singular, else 0.
        integer :: singular_pivot = 0
    end type newton_report_t

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

    !> Solve F(x) = 0 by Newton's method from the first guess in `x`.
    !!
    !! Codes: HOLOSYM_SINGULAR_MATRIX (a pivot below threshold; `report%singular_pivot`
    !! says which), HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED,
    !! HOLOSYM_NONFINITE_VALUE, or a code passed on from the system's evaluations.
    !! On failure `x` holds the first guess again.
    subroutine newton_solve(system, x, settings, scale, report, status)
        class(nonlinear_system), intent(inout) :: system !! the equations
        real(wp), intent(inout) :: x(:)                 !! first guess in, solution out
        type(newton_settings_t), intent(in) :: settings !! tolerances and limits
        real(wp), intent(in) :: scale     !! typical magnitude of x (absolute floor of the test)
        type(newton_report_t), intent(out) :: report    !! iterations and diagnostics
        type(holosym_status_t), intent(out), optional :: status !! outcome
        real(wp) :: jac(size(x), size(x)), rhs(size(x), 1), guess(size(x)), row_scale(size(x))
        real(wp) :: correction, previous, tolerance, pivot_ratio, rate
        integer :: pivots(size(x)), info, iter, growth, nx, i
        type(holosym_status_t) :: eval_status

        nx = size(x)
        guess = x
        if (settings%max_iterations < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "max_iterations must be >= 1, got " &
                // int_str(settings%max_iterations))
            return
        end if
        previous = huge(1.0_wp)
        growth = 0
        report%pivot_ratio = huge(1.0_wp)
        tolerance = settings%pivot_tolerance
        if (tolerance <= 0) tolerance = default_pivot_tolerance(nx)
        do iter = 1, settings%max_iterations
            report%iterations = iter
            call system%residual(x, rhs(:, 1), eval_status)
            if (.not. eval_status%ok()) then
                call fail(eval_status%code, eval_status%message)
                return
            end if
            call system%jacobian(x, jac, eval_status)
            if (.not. eval_status%ok()) then
                call fail(eval_status%code, eval_status%message)
                return
            end if
            if (.not. all(is_finite(rhs)) .or. .not. all(is_finite(jac))) then
                call fail(HOLOSYM_NONFINITE_VALUE, "non-finite residual or Jacobian at Newton " &
                    // "iteration " // int_str(iter))
                return
            end if
            ! Row equilibration makes the pivot test independent of the equations' units.
            do i = 1, nx
                row_scale(i) = maxval(abs(jac(i, :)))
                if (row_scale(i) > 0) then
                    jac(i, :) = jac(i, :) / row_scale(i)
                    rhs(i, 1) = rhs(i, 1) / row_scale(i)
                end if
            end do
            call lu_factor(jac, pivots, info, tolerance, pivot_ratio)
            if (info /= 0) then
                report%singular_pivot = info
                report%pivot_ratio = 0
                call fail(HOLOSYM_SINGULAR_MATRIX, "Newton Jacobian singular at pivot " // &
                    int_str(info) // " of " // int_str(nx) // " (relative threshold " // &
                    real_str(tolerance) // ")")
                return
            end if
            report%pivot_ratio = min(report%pivot_ratio, pivot_ratio)
            call lu_solve(jac, pivots, rhs)
            x = x - rhs(:, 1)
            correction = maxval(abs(rhs(:, 1))) / max(scale, maxval(abs(x)))
            report%last_correction = correction
            if (.not. is_finite(correction)) then
                call fail(HOLOSYM_NEWTON_DIVERGED, "Newton correction not finite at " // &
                    "iteration " // int_str(iter))
                return
            end if
            if (correction <= settings%tolerance) exit
            ! With contraction rate theta the remaining error is about theta/(1-theta) * dx.
            rate = correction / previous
            if (iter > 1 .and. rate < 1) then
                if (rate / (1 - rate) * correction <= settings%tolerance) exit
            end if
            if (correction >= previous .and. correction <= settings%stagnation_level) exit
            if (correction > previous .and. correction > settings%stagnation_level) then
                growth = growth + 1
                if (growth >= settings%max_growth) then
                    call fail(HOLOSYM_NEWTON_DIVERGED, "Newton corrections grew " // &
                        int_str(growth) // " times in a row (last " // real_str(correction) // &
                        ") at iteration " // int_str(iter))
                    return
                end if
            else
                growth = 0
            end if
            if (iter == settings%max_iterations) then
                call fail(HOLOSYM_NEWTON_NOT_CONVERGED, "Newton not converged after " // &
                    int_str(iter) // " iterations (last correction " // real_str(correction) // ")")
                return
            end if
            previous = correction
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")

    contains

        subroutine fail(code, message)
            integer, intent(in) :: code
            character(len=*), intent(in) :: message
            x = guess
            call set_status(status, code, message)
        end subroutine fail

    end subroutine newton_solve

end module holosym_newton
