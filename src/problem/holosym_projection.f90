!> category: internal module (use holosym)
!! Projection of a state onto the constraint manifold {phi(q) = 0, Phi(q) H_p(q, p) = 0}.
!!
!! The integrator accepts a start state only when both constraints hold to round-off
!! (scaled residuals at most `manifold_tolerance_default`, see holosym_manifold).
!! `project_to_manifold` moves a nearby state there in two stages:
!!
!! 1. positions: Newton's method along the constraint normals,
!!    q <- q - Phi(q)^T (Phi(q) Phi(q)^T)^(-1) phi(q), iterated (Gauss-Newton for the
!!    nearest point; it converges quadratically to a point close to the orthogonal projection);
!! 2. momenta at the new q: p <- p - Phi(q)^T beta with the m multipliers beta solving
!!    g(beta) = Phi(q) H_p(q, p - Phi(q)^T beta) = 0 by Newton's method, whose Jacobian is
!!    -Phi H_pp Phi^T (exact in one iteration when H is quadratic in p).
!!
!! Both stages stop at the round-off level of the scaled residuals and accept the result
!! when it is at most `tolerance`. On failure the caller's q and p are unchanged.
!!
!! `project_sparse` does the same for a state already within a small distance of the
!! manifold (a step's end iterated to a loose Newton tolerance) of a system with constant
!! diagonal mass and a sparse Phi, in work linear in m for banded constraints.
module holosym_projection
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED
    use holosym_linalg, only: lu_factor, lu_solve
    use holosym_problem, only: constrained_hamiltonian, clear_refusal, check_refusal
    use holosym_manifold, only: manifold_residuals, manifold_tolerance_default, gram_band, &
        band_cholesky, band_cholesky_solve, sparse_scaled_position
    implicit none
    private

    public :: project_to_manifold, projection_report_t, project_sparse

    !> Default iteration limit of each stage; Newton converges quadratically, so a state
    !! that needs more is not "nearby" (same limit as newton_settings_t).
    integer, parameter, public :: projection_max_iterations_default = 50
    !> Scaled residual at which a stage stops at once: a few epsilon, the round-off of
    !! evaluating phi or Phi H_p (the acceptance test uses the looser `tolerance`).
    real(wp), parameter :: round_off_target = 4 * epsilon(1.0_wp)
    !> Consecutive growing Newton corrections after which a stage is declared diverged
    !! (as in newton_settings_t%max_growth).
    integer, parameter :: max_growth = 3
    !> Corrections of `project_sparse`'s position stage: its state is within the Newton
    !! error of a step (at most 1e-3), so Gauss-Newton's quadratic convergence reaches
    !! round-off in two or three; more means the state was not close.
    integer, parameter :: sparse_iterations = 6

    !> What the projection did.
    type :: projection_report_t
        !> Newton iterations of the position stage (0 when q was already on the manifold).
        integer :: position_iterations = 0
        !> Newton iterations of the momentum stage.
        integer :: momentum_iterations = 0
        !> Scaled residual max_l |phi_l| / (1 + |q| |Phi_l|) before and after.
        real(wp) :: position_before = 0
        real(wp) :: position_after = 0
        !> Scaled residual of the hidden constraint before (at the given q) and after.
        real(wp) :: velocity_before = 0
        real(wp) :: velocity_after = 0
        !> max |q_new - q| and max |p_new - p|.
        real(wp) :: position_shift = 0
        real(wp) :: momentum_shift = 0
    end type projection_report_t

contains

    !> Project (q, p) onto the constraint manifold of `sys`, in place.
    !!
    !! On success both scaled residuals (as defined by `manifold_residuals`) are at most
    !! `tolerance`, so the integrator accepts the state. On failure q and p are unchanged.
    !! Codes: HOLOSYM_INVALID_DIMENSION (n < 1, m < 0 or m >= n), HOLOSYM_SIZE_MISMATCH
    !! (size(q) or size(p) /= n), HOLOSYM_INVALID_ARGUMENT (q or p not finite, tolerance not
    !! positive and finite, max_iterations < 1), HOLOSYM_NONFINITE_VALUE (a user procedure
    !! returned NaN or Inf), HOLOSYM_RANK_DEFICIENT_CONSTRAINTS (Phi Phi^T singular at an
    !! iterate), HOLOSYM_SINGULAR_MATRIX (Phi H_pp Phi^T singular: H is degenerate in p
    !! along the constraint normals), HOLOSYM_NEWTON_DIVERGED (Newton's corrections grew
    !! three times in a row or the iterate became non-finite: the state is too far from
    !! the manifold),
    !! HOLOSYM_NEWTON_NOT_CONVERGED (iteration limit, or stalled above `tolerance`),
    !! HOLOSYM_OUTSIDE_DOMAIN (a procedure of the system refused a point, `refuse`).
    subroutine project_to_manifold(sys, q, p, status, tolerance, max_iterations, report)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(inout) :: q(:) !! coordinates (n): in, projected out
        real(wp), intent(inout) :: p(:) !! momenta (n): in, projected out
        type(holosym_status_t), intent(out), optional :: status !! outcome
        !> Largest accepted scaled residual (default `manifold_tolerance_default`).
        real(wp), intent(in), optional :: tolerance
        !> Iteration limit of each stage (default `projection_max_iterations_default`).
        integer, intent(in), optional :: max_iterations
        type(projection_report_t), intent(out), optional :: report !! what was done
        type(projection_report_t) :: local_report
        type(holosym_status_t) :: local
        real(wp), allocatable :: qw(:), pw(:)
        real(wp) :: accept, position, velocity
        integer :: limit

        accept = manifold_tolerance_default
        if (present(tolerance)) accept = tolerance
        limit = projection_max_iterations_default
        if (present(max_iterations)) limit = max_iterations
        if (present(report)) report = local_report
        if (sys%n < 1 .or. sys%m < 0 .or. sys%m >= sys%n) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "need n >= 1 and 0 <= m < n; " &
                // "got n = " // int_str(sys%n) // ", m = " // int_str(sys%m))
            return
        else if (size(q) /= sys%n .or. size(p) /= sys%n) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q and p must have size n = " // &
                int_str(sys%n) // "; got " // int_str(size(q)) // " and " // int_str(size(p)))
            return
        else if (.not. (all(is_finite(q)) .and. all(is_finite(p)))) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "q or p contains NaN or Inf")
            return
        else if (.not. is_finite(accept)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tolerance must be positive " // &
                "and finite; got " // real_str(accept))
            return
        else if (accept <= 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tolerance must be positive " // &
                "and finite; got " // real_str(accept))
            return
        else if (limit < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "max_iterations must be >= 1; " &
                // "got " // int_str(limit))
            return
        end if
        if (sys%m == 0) then
            call set_status(status, HOLOSYM_SUCCESS, "")
            return
        end if

        call clear_refusal()
        qw = q
        pw = p
        call manifold_residuals(sys, q, p, position, velocity, local_report%position_before, &
                                local_report%velocity_before)
        call project_positions(sys, qw, accept, limit, local_report, local)
        if (local%ok()) call project_momenta(sys, qw, pw, accept, limit, local_report, local)
        if (local%ok()) then
            ! The acceptance test of the integrator, on the final state.
            call manifold_residuals(sys, qw, pw, position, velocity, &
                                    local_report%position_after, local_report%velocity_after)
            if (.not. (local_report%position_after <= accept .and. &
                       local_report%velocity_after <= accept)) then
                call set_status(local, HOLOSYM_NEWTON_NOT_CONVERGED, "projected state still " &
                    // "off the manifold: scaled residuals " // &
                    real_str(local_report%position_after) // " (phi) and " // &
                    real_str(local_report%velocity_after) // " (Phi H_p) > tolerance " // &
                    real_str(accept))
            end if
        end if
        call check_refusal(local, "project_to_manifold")
        if (.not. local%ok()) then
            if (present(report)) report = local_report
            call set_status(status, local%code, local%message)
            return
        end if
        local_report%position_shift = maxval(abs(qw - q))
        local_report%momentum_shift = maxval(abs(pw - p))
        q = qw
        p = pw
        if (present(report)) report = local_report
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine project_to_manifold

    !> Project (q, p), close to the manifold, onto it for a system whose H_p is linear in
    !! p with the constant diagonal H_pp = W = diag(`inverse_mass`) (a declared diagonal
    !! mass), through the pattern of Phi the system declares (`rows`, `columns` from
    !! `constraint_sparsity`; `constraint_jacobian_values` fills it):
    !! q <- q - W Phi^T G^-1 phi(q) with G = Phi W Phi^T (band Cholesky in `order`),
    !! repeated until the scaled residual of phi is at round-off, then at the new q
    !! p <- p - Phi^T G^-1 Phi H_p(q, p), exact in one step for such an H. `position` and
    !! `velocity` are max |phi| and max |Phi H_p| at the result. Work: a few evaluations
    !! of phi, Phi and H_p, and m times G's band squared. On failure q and p are unchanged. Codes:
    !! HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS (a pivot of G below
    !! m epsilon relative), HOLOSYM_NEWTON_NOT_CONVERGED (phi above `accept` after
    !! `sparse_iterations` corrections: the state was not close).
    subroutine project_sparse(sys, rows, columns, order, inverse_mass, q, p, position, &
                              velocity, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        integer, intent(in) :: rows(:)     !! pattern of Phi: constraint of each entry
        integer, intent(in) :: columns(:)  !! pattern of Phi: coordinate of each entry
        integer, intent(in) :: order(:)    !! position of each constraint in G's band order
        real(wp), intent(in) :: inverse_mass(:) !! W's diagonal (n)
        real(wp), intent(inout) :: q(:)    !! coordinates (n): in, projected out
        real(wp), intent(inout) :: p(:)    !! momenta (n): in, projected out
        real(wp), intent(out) :: position  !! max |phi| at the projected state
        real(wp), intent(out) :: velocity  !! max |Phi H_p| at the projected state
        type(holosym_status_t), intent(out) :: status !! outcome
        real(wp), allocatable :: band(:, :)
        real(wp) :: qw(size(q)), pw(size(p)), phi(sys%m), values(size(rows)), hp(size(p))
        real(wp) :: multipliers(sys%m), scaled
        integer :: iter
        position = 0
        velocity = 0
        call set_status(status, HOLOSYM_SUCCESS, "")
        if (sys%m == 0) return
        qw = q
        pw = p
        do iter = 0, sparse_iterations
            call sparse_values(sys, rows, columns, qw, phi, values, status)
            if (.not. status%ok()) return
            call sparse_gram(sys, rows, columns, order, inverse_mass, values, band, status)
            if (.not. status%ok()) return
            scaled = sparse_scaled_position(qw, phi, rows, values)
            if (scaled <= round_off_target) exit
            if (iter == sparse_iterations) then
                if (scaled <= manifold_tolerance_default) exit
                call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "position projection " &
                    // "not converged after " // int_str(iter) // " corrections (scaled " // &
                    "max|phi| = " // real_str(scaled) // ")")
                return
            end if
            multipliers = phi
            call band_cholesky_solve(band, order, multipliers)
            call subtract_transpose(rows, columns, values, multipliers, qw, inverse_mass)
        end do
        call sys%dh_dp(qw, pw, hp)
        multipliers = hidden_constraint(sys%m, rows, columns, values, hp)
        call band_cholesky_solve(band, order, multipliers)
        call subtract_transpose(rows, columns, values, multipliers, pw)
        call sys%dh_dp(qw, pw, hp)
        if (.not. (all(is_finite(hp)) .and. all(is_finite(pw)))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "dh_dp returned NaN or Inf " // &
                "in the momentum projection")
            return
        end if
        position = maxval(abs(phi))
        velocity = maxval(abs(hidden_constraint(sys%m, rows, columns, values, hp)))
        q = qw
        p = pw
    end subroutine project_sparse

    !> phi and Phi (on its pattern) at q, or HOLOSYM_NONFINITE_VALUE.
    subroutine sparse_values(sys, rows, columns, q, phi, values, status)
        class(constrained_hamiltonian), intent(in) :: sys
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:), values(:)
        type(holosym_status_t), intent(inout) :: status
        call sys%constraint(q, phi)
        call sys%constraint_jacobian_values(q, rows, columns, values)
        if (.not. (all(is_finite(phi)) .and. all(is_finite(values)))) &
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint or " // &
                "constraint_jacobian returned NaN or Inf in the position projection")
    end subroutine sparse_values

    !> G = Phi W Phi^T factored (`band_cholesky`), or HOLOSYM_RANK_DEFICIENT_CONSTRAINTS.
    subroutine sparse_gram(sys, rows, columns, order, inverse_mass, values, band, status)
        class(constrained_hamiltonian), intent(in) :: sys
        integer, intent(in) :: rows(:), columns(:), order(:)
        real(wp), intent(in) :: inverse_mass(:), values(:)
        real(wp), allocatable, intent(out) :: band(:, :)
        type(holosym_status_t), intent(inout) :: status
        integer :: failed
        call gram_band(sys%n, sys%m, rows, columns, order, values, band, inverse_mass)
        call band_cholesky(band, sys%m * epsilon(1.0_wp), failed)
        if (failed > 0) call set_status(status, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, "the " // &
            "constraint Jacobian Phi is rank deficient in the projection: pivot " // &
            int_str(failed) // " of " // int_str(sys%m) // " of Phi M^-1 Phi^T below m " // &
            "epsilon relative")
    end subroutine sparse_gram

    !> Phi v for a sparse Phi.
    pure function hidden_constraint(m, rows, columns, values, v) result(hidden)
        integer, intent(in) :: m, rows(:), columns(:)
        real(wp), intent(in) :: values(:), v(:)
        real(wp) :: hidden(m)
        integer :: e
        hidden = 0
        do e = 1, size(rows)
            hidden(rows(e)) = hidden(rows(e)) + values(e) * v(columns(e))
        end do
    end function hidden_constraint

    !> x <- x - W Phi^T y for a sparse Phi (W = diag(weights), or the identity).
    pure subroutine subtract_transpose(rows, columns, values, y, x, weights)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(in) :: values(:), y(:)
        real(wp), intent(inout) :: x(:)
        real(wp), intent(in), optional :: weights(:)
        real(wp) :: shift(size(x))
        integer :: e
        shift = 0
        do e = 1, size(rows)
            shift(columns(e)) = shift(columns(e)) + values(e) * y(rows(e))
        end do
        if (present(weights)) shift = weights * shift
        x = x - shift
    end subroutine subtract_transpose

    !> Stage 1: q <- q - Phi^T (Phi Phi^T)^(-1) phi until |phi| is at round-off.
    subroutine project_positions(sys, q, accept, limit, report, status)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(inout) :: q(:)
        real(wp), intent(in) :: accept
        integer, intent(in) :: limit
        type(projection_report_t), intent(inout) :: report
        type(holosym_status_t), intent(out) :: status
        real(wp) :: phi(sys%m), jac(sys%m, sys%n), gram(sys%m, sys%m), rhs(sys%m, 1)
        real(wp) :: residual, previous, shift(sys%n), last_correction
        integer :: pivots(sys%m), info, iter, growth, l

        previous = huge(1.0_wp)
        last_correction = huge(1.0_wp)
        growth = 0
        do iter = 0, limit
            call sys%constraint(q, phi)
            call sys%constraint_jacobian(q, jac)
            if (.not. (all(is_finite(phi)) .and. all(is_finite(jac)))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint or " // &
                    "constraint_jacobian returned NaN or Inf at projection iteration " // &
                    int_str(iter))
                return
            end if
            residual = 0
            do l = 1, sys%m
                residual = max(residual, abs(phi(l)) / (1 + maxval(abs(q)) * &
                                                        maxval(abs(jac(l, :)))))
            end do
            if (residual <= round_off_target) exit
            ! Stalled at the round-off floor: accept if the floor is within tolerance.
            if (residual >= previous .and. previous <= accept) exit
            if (iter == limit) then
                call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "position projection " &
                    // "not converged after " // int_str(limit) // " iterations (scaled " // &
                    "max|phi| = " // real_str(residual) // ")")
                return
            end if
            previous = min(previous, residual)
            gram = matmul(jac, transpose(jac))
            call lu_factor(gram, pivots, info)
            if (info /= 0) then
                call set_status(status, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, "the constraint " // &
                    "Jacobian Phi is rank deficient at projection iteration " // int_str(iter) &
                    // ": constraint " // int_str(info) // " of " // int_str(sys%m) // &
                    " is (nearly) a combination of the others (pivot of Phi Phi^T below m " // &
                    "epsilon)")
                return
            end if
            rhs(:, 1) = phi
            call lu_solve(gram, pivots, rhs)
            shift = matmul(transpose(jac), rhs(:, 1))
            q = q - shift
            report%position_iterations = iter + 1
            call track_correction("position", "scaled max|phi|", maxval(abs(shift)), residual, &
                q, iter + 1, last_correction, growth, status)
            if (.not. status%ok()) then
                status%message = status%message // "; the state is too far from the manifold"
                return
            end if
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine project_positions

    !> Stage 2 at fixed q: p <- p - Phi^T beta with Phi H_p(q, p - Phi^T beta) = 0.
    subroutine project_momenta(sys, q, p, accept, limit, report, status)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:)
        real(wp), intent(inout) :: p(:)
        real(wp), intent(in) :: accept
        integer, intent(in) :: limit
        type(projection_report_t), intent(inout) :: report
        type(holosym_status_t), intent(out) :: status
        real(wp) :: jac(sys%m, sys%n), hp(sys%n), hidden(sys%m), rhs(sys%m, 1)
        real(wp) :: hqq(sys%n, sys%n), hqp(sys%n, sys%n), hpp(sys%n, sys%n)
        real(wp) :: reduced(sys%m, sys%m), residual, previous, shift(sys%n)
        real(wp) :: last_correction
        integer :: pivots(sys%m), info, iter, growth, l

        call sys%constraint_jacobian(q, jac)
        previous = huge(1.0_wp)
        last_correction = huge(1.0_wp)
        growth = 0
        do iter = 0, limit
            call sys%dh_dp(q, p, hp)
            if (.not. all(is_finite(hp))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "dh_dp returned NaN or Inf " &
                    // "at momentum projection iteration " // int_str(iter))
                return
            end if
            hidden = matmul(jac, hp)
            residual = 0
            do l = 1, sys%m
                residual = max(residual, abs(hidden(l)) / (1 + sum(abs(jac(l, :)) * abs(hp))))
            end do
            if (residual <= round_off_target) exit
            if (residual >= previous .and. previous <= accept) exit
            if (iter == limit) then
                call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "momentum projection " &
                    // "not converged after " // int_str(limit) // " iterations (scaled " // &
                    "max|Phi H_p| = " // real_str(residual) // ")")
                return
            end if
            previous = min(previous, residual)
            call sys%hessian(q, p, hqq, hqp, hpp)
            if (.not. all(is_finite(hpp))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "hessian (d2H/dp2) returned " &
                    // "NaN or Inf at momentum projection iteration " // int_str(iter))
                return
            end if
            reduced = matmul(jac, matmul(hpp, transpose(jac)))
            call lu_factor(reduced, pivots, info)
            if (info /= 0) then
                call set_status(status, HOLOSYM_SINGULAR_MATRIX, "momentum projection: " // &
                    "Phi H_pp Phi^T is singular (pivot " // int_str(info) // " of " // &
                    int_str(sys%m) // "); H is degenerate in p along the constraint normals")
                return
            end if
            rhs(:, 1) = hidden
            call lu_solve(reduced, pivots, rhs)
            shift = matmul(transpose(jac), rhs(:, 1))
            p = p - shift
            report%momentum_iterations = iter + 1
            call track_correction("momentum", "scaled max|Phi H_p|", maxval(abs(shift)), &
                residual, p, iter + 1, last_correction, growth, status)
            if (.not. status%ok()) return
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine project_momenta

    !> Divergence test shared by both stages: Newton's corrections shrink near a solution,
    !! so `max_growth` growing ones in a row, or a non-finite iterate, mean divergence.
    subroutine track_correction(stage, residual_name, correction, residual, x, iteration, &
                                last_correction, growth, status)
        character(len=*), intent(in) :: stage          !! "position" or "momentum"
        character(len=*), intent(in) :: residual_name  !! what `residual` measures
        real(wp), intent(in) :: correction   !! size of this iteration's correction
        real(wp), intent(in) :: residual     !! scaled residual before it
        real(wp), intent(in) :: x(:)         !! the new iterate
        integer, intent(in) :: iteration     !! iteration number
        real(wp), intent(inout) :: last_correction !! previous correction, updated
        integer, intent(inout) :: growth     !! growing corrections in a row, updated
        type(holosym_status_t), intent(inout) :: status !! HOLOSYM_NEWTON_DIVERGED on failure
        if (correction > last_correction) then
            growth = growth + 1
        else
            growth = 0
        end if
        last_correction = correction
        if (growth >= max_growth) then
            call set_status(status, HOLOSYM_NEWTON_DIVERGED, stage // " projection " // &
                "diverged: the correction grew " // int_str(growth) // " times in a row to " // &
                real_str(correction) // " (" // residual_name // " = " // real_str(residual) // ")")
        else if (.not. all(is_finite(x))) then
            call set_status(status, HOLOSYM_NEWTON_DIVERGED, stage // " projection produced " // &
                "a non-finite iterate at iteration " // int_str(iteration))
        else
            call set_status(status, HOLOSYM_SUCCESS, "")
        end if
    end subroutine track_correction

end module holosym_projection
