!> The non-symplectic reference of the long-run figure: the index-1 form of the equations
!! of motion integrated by the classical fourth-order Runge-Kutta method.
!!
!! Differentiating the hidden constraint Phi(q) H_p(q, p) = 0 once more gives the
!! multipliers as a function of the state, and with them an ordinary differential equation:
!!     q' = H_p,   p' = -H_q - Phi^T lambda,
!!     (Phi H_pp Phi^T) lambda = phi''(v, v) + Phi H_pq v - Phi H_pp H_q,   v = H_p,
!! with phi''(v, v)_l = v^T (d2 phi_l/dq2) v and H_pq = dH_p/dq. Its exact flow keeps both
!! constraint levels, but a standard method applied to it does not: the constraints drift,
!! and so does the energy, which is what the figure shows next to the symplectic schemes.
!! The second derivatives come from the system's `hessian` and `constraint_hessian`.
module holosym_index1
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NONFINITE_VALUE, &
        HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_STEP_SIZE
    use holosym_problem, only: constrained_hamiltonian
    use holosym_linalg, only: lu_factor, lu_solve
    implicit none
    private

    public :: index1_rhs, rk4_step

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The right-hand side (q', p') of the index-1 form at (q, p).
    !! Codes: HOLOSYM_SINGULAR_MATRIX (Phi H_pp Phi^T singular), HOLOSYM_NONFINITE_VALUE.
    subroutine index1_rhs(sys, q, p, dq, dp, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:)   !! coordinates (n)
        real(wp), intent(in) :: p(:)   !! momenta (n)
        real(wp), intent(out) :: dq(:) !! q'
        real(wp), intent(out) :: dp(:) !! p'
        type(holosym_status_t), intent(out) :: status !! outcome
        real(wp) :: hq(sys%n), v(sys%n), hqq(sys%n, sys%n), hqp(sys%n, sys%n)
        real(wp) :: hpp(sys%n, sys%n), jac(sys%m, sys%n), curvature(sys%n, sys%n, sys%m)
        real(wp) :: matrix(sys%m, sys%m), rhs(sys%m, 1), drift(sys%n)
        integer :: pivots(sys%m), info, l

        call sys%dh_dq(q, p, hq)
        call sys%dh_dp(q, p, v)
        dq = v
        dp = -hq
        call set_status(status, HOLOSYM_SUCCESS, "")
        if (sys%m == 0) return
        call sys%hessian(q, p, hqq, hqp, hpp)
        call sys%constraint_jacobian(q, jac)
        call sys%constraint_hessian(q, curvature)
        ! Phi H_pq v - Phi H_pp H_q, with (H_pq v)_i = sum_k hqp(k, i) v_k.
        drift = matmul(v, hqp) - matmul(hpp, hq)
        do l = 1, sys%m
            rhs(l, 1) = dot_product(v, matmul(curvature(:, :, l), v)) + &
                dot_product(jac(l, :), drift)
        end do
        matrix = matmul(jac, matmul(hpp, transpose(jac)))
        call lu_factor(matrix, pivots, info)
        if (info /= 0) then
            call set_status(status, HOLOSYM_SINGULAR_MATRIX, "Phi H_pp Phi^T is singular " // &
                "(pivot " // int_str(info) // ")")
            return
        end if
        call lu_solve(matrix, pivots, rhs)
        dp = dp - matmul(rhs(:, 1), jac)
        if (.not. (all(is_finite(dq)) .and. all(is_finite(dp)))) call set_status(status, &
            HOLOSYM_NONFINITE_VALUE, "the index-1 right-hand side is NaN or Inf")
    end subroutine index1_rhs

    !> One classical Runge-Kutta step of size h for the index-1 form, in place; on failure
    !! q and p are unchanged. Codes: those of `index1_rhs`, HOLOSYM_SIZE_MISMATCH,
    !! HOLOSYM_INVALID_STEP_SIZE.
    subroutine rk4_step(sys, q, p, h, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(inout) :: q(:) !! coordinates (n)
        real(wp), intent(inout) :: p(:) !! momenta (n)
        real(wp), intent(in) :: h       !! step size > 0
        type(holosym_status_t), intent(out) :: status !! outcome
        real(wp), dimension(size(q)) :: k1q, k2q, k3q, k4q, k1p, k2p, k3p, k4p
        if (size(q) /= sys%n .or. size(p) /= sys%n) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q and p must have size n")
            return
        else if (.not. (is_finite(h) .and. h > 0)) then
            call set_status(status, HOLOSYM_INVALID_STEP_SIZE, "h must be positive")
            return
        end if
        call index1_rhs(sys, q, p, k1q, k1p, status)
        if (status%ok()) call index1_rhs(sys, q + h / 2 * k1q, p + h / 2 * k1p, k2q, k2p, status)
        if (status%ok()) call index1_rhs(sys, q + h / 2 * k2q, p + h / 2 * k2p, k3q, k3p, status)
        if (status%ok()) call index1_rhs(sys, q + h * k3q, p + h * k3p, k4q, k4p, status)
        if (.not. status%ok()) return
        q = q + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
        p = p + h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p)
    end subroutine rk4_step

end module holosym_index1

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_index1) holosym_index1_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_index1_app
