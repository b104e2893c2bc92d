!> category: internal module (use holosym)
!! A consistent start state from what a user knows: positions that nearly satisfy the
!! constraints, and velocities q' instead of momenta.
!!
!! `state_from_velocities(sys, q, velocity, p)`:
!! 1. projects q onto {phi(q) = 0} (the position stage of `project_to_manifold`);
!! 2. finds p with dH/dp(q, p) = q' by Newton's method on the n x n matrix d2H/dp2 (one
!!    iteration when H is quadratic in p, as in every mechanical system: H = (p - a(q))^T
!!    T(q) (p - a(q))/2 + U(q));
!! 3. projects p onto the hidden constraint Phi(q) dH/dp(q, p) = 0 (the momentum stage of
!!    `project_to_manifold`): p <- p - Phi^T beta. For H quadratic in p this removes the
!!    normal part of the velocity in the metric of the kinetic energy, so a q' that is
!!    already tangent to the constraints is kept exactly.
!! The result passes the integrator's start test. On failure q and p are unchanged.
module holosym_initial_states
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NONFINITE_VALUE, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NEWTON_NOT_CONVERGED
    use holosym_linalg, only: lu_factor, lu_solve
    use holosym_problem, only: constrained_hamiltonian
    use holosym_manifold, only: manifold_tolerance_default
    use holosym_projection, only: project_to_manifold, projection_report_t, &
        projection_max_iterations_default
    implicit none
    private

    public :: state_from_velocities

    !> Relative size of a Newton correction of p at which stage 2 has converged.
    real(wp), parameter :: momentum_tolerance = 8 * epsilon(1.0_wp)

contains

    !> A state on the constraint manifold from positions q (nearly on it) and velocities
    !! q' (see the module's documentation for the three stages).
    !!
    !! Codes: HOLOSYM_INVALID_DIMENSION (n < 1, m < 0 or m >= n), HOLOSYM_SIZE_MISMATCH
    !! (q, velocity or p not of size n), HOLOSYM_INVALID_ARGUMENT (q or velocity not finite,
    !! tolerance or max_iterations out of range), HOLOSYM_NONFINITE_VALUE (dh_dp or hessian
    !! returned NaN or Inf), HOLOSYM_SINGULAR_MATRIX (d2H/dp2 singular: the velocities do
    !! not determine the momenta), HOLOSYM_NEWTON_NOT_CONVERGED (dH/dp(q, p) = q' not solved
    !! within max_iterations: H is far from quadratic in p), and the codes of
    !! `project_to_manifold`. On failure q and p are unchanged.
    subroutine state_from_velocities(sys, q, velocity, p, status, tolerance, max_iterations, &
                                     report)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(inout) :: q(:)        !! coordinates (n): in, projected out
        real(wp), intent(in) :: velocity(:)    !! velocities q' (n)
        real(wp), intent(inout) :: p(:)        !! momenta (n): out (unchanged on failure)
        type(holosym_status_t), intent(out), optional :: status !! outcome
        !> Largest accepted scaled residual (default `manifold_tolerance_default`).
        real(wp), intent(in), optional :: tolerance
        !> Iteration limit of each stage (default `projection_max_iterations_default`).
        integer, intent(in), optional :: max_iterations
        !> The position stage's iterations and shift, the momentum stage's iterations and
        !! residuals (those of `project_to_manifold`).
        type(projection_report_t), intent(out), optional :: report
        type(projection_report_t) :: position_report, momentum_report
        type(holosym_status_t) :: local
        real(wp), allocatable :: qw(:), pw(:)
        real(wp) :: accept
        integer :: limit

        accept = manifold_tolerance_default
        if (present(tolerance)) accept = tolerance
        limit = projection_max_iterations_default
        if (present(max_iterations)) limit = max_iterations
        if (present(report)) report = projection_report_t()
        if (sys%n < 1 .or. sys%m < 0 .or. sys%m >= sys%n) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "need n >= 1 and 0 <= m < n; " &
                // "got n = " // int_str(sys%n) // ", m = " // int_str(sys%m))
            return
        else if (size(q) /= sys%n .or. size(velocity) /= sys%n .or. size(p) /= sys%n) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q, velocity and p must have " // &
                "size n = " // int_str(sys%n) // "; got " // int_str(size(q)) // ", " // &
                int_str(size(velocity)) // " and " // int_str(size(p)))
            return
        else if (.not. (all(is_finite(q)) .and. all(is_finite(velocity)))) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "q or velocity contains NaN " // &
                "or Inf")
            return
        end if

        ! 1. Positions (the momenta of this call are discarded).
        qw = q
        allocate (pw(sys%n))
        pw = 0
        call project_to_manifold(sys, qw, pw, local, accept, limit, position_report)
        ! 2. Momenta from velocities at the projected positions.
        if (local%ok()) call momenta_from_velocities(sys, qw, velocity, pw, limit, local)
        ! 3. Momenta onto the hidden constraint (positions are already on the manifold).
        if (local%ok()) call project_to_manifold(sys, qw, pw, local, accept, limit, &
                                                 momentum_report)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        if (present(report)) then
            report = momentum_report
            report%position_iterations = position_report%position_iterations
            report%position_before = position_report%position_before
            report%position_shift = position_report%position_shift
        end if
        q = qw
        p = pw
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine state_from_velocities

    !> Newton's method for dH/dp(q, p) = velocity from p = 0 (exact after one iteration
    !! when H is quadratic in p).
    subroutine momenta_from_velocities(sys, q, velocity, p, limit, status)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), velocity(:)
        real(wp), intent(inout) :: p(:)
        integer, intent(in) :: limit
        type(holosym_status_t), intent(out) :: status
        real(wp) :: hqq(sys%n, sys%n), hqp(sys%n, sys%n), hpp(sys%n, sys%n)
        real(wp) :: residual(sys%n, 1), hp(sys%n), correction
        integer :: pivots(sys%n), info, iter

        p = 0
        do iter = 1, limit
            call sys%dh_dp(q, p, hp)
            call sys%hessian(q, p, hqq, hqp, hpp)
            if (.not. (all(is_finite(hp)) .and. all(is_finite(hpp)))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "dh_dp or hessian " // &
                    "returned NaN or Inf at Newton iteration " // int_str(iter) // &
                    " for the momenta")
                return
            end if
            call lu_factor(hpp, pivots, info)
            if (info /= 0) then
                call set_status(status, HOLOSYM_SINGULAR_MATRIX, "d2H/dp2 is singular " // &
                    "(pivot " // int_str(info) // " of " // int_str(sys%n) // "): the " // &
                    "velocities do not determine the momenta")
                return
            end if
            residual(:, 1) = hp - velocity
            call lu_solve(hpp, pivots, residual)
            p = p - residual(:, 1)
            correction = maxval(abs(residual(:, 1)))
            if (.not. all(is_finite(p))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "the momenta became NaN " // &
                    "or Inf at Newton iteration " // int_str(iter))
                return
            end if
            ! Quadratic H: the first correction is exact, the second at round-off.
            if (correction <= momentum_tolerance * max(1.0_wp, maxval(abs(p))) .or. &
                (iter == 1 .and. is_quadratic(sys, q, p, velocity))) then
                call set_status(status, HOLOSYM_SUCCESS, "")
                return
            end if
        end do
        call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "dH/dp(q, p) = velocity not " // &
            "solved for p in " // int_str(limit) // " Newton iterations (last correction " // &
            real_str(correction) // ")")
    end subroutine momenta_from_velocities

    !> Whether dH/dp(q, p) matches the velocity to round-off after the first iteration.
    logical function is_quadratic(sys, q, p, velocity)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), velocity(:)
        real(wp) :: hp(sys%n)
        call sys%dh_dp(q, p, hp)
        is_quadratic = maxval(abs(hp - velocity)) <= &
            64 * epsilon(1.0_wp) * max(1.0_wp, maxval(abs(velocity)))
    end function is_quadratic

end module holosym_initial_states
