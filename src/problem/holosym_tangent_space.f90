!> category: internal module (use holosym)
!! The tangent space of the constraint manifold {phi(q) = 0, Phi(q) H_p(q, p) = 0} at a
!! state: the directions (dq, dp) with Phi dq = 0 and d(Phi H_p) = 0, i.e. C (dq; dp) = 0
!! for the 2m x 2n matrix
!!
!!   C = [ Phi                                   0          ]
!!       [ (phi_l'' H_p)^T + Phi H_qp^T           Phi H_pp   ]   (row l of the second block).
!!
!! Directions off it are what the step's derivative must not be given (the step map is
!! symplectic only on the manifold); `tangent_residual` measures how far a direction is
!! from it and `project_tangent` projects a direction onto it.
module holosym_tangent_space
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use holosym_kinds, only: wp
    use holosym_problem, only: constrained_hamiltonian
    use holosym_linalg, only: lu_factor, lu_solve
    use holosym_status_codes, only: holosym_status_t, set_status, is_finite, int_str, &
        HOLOSYM_SUCCESS, HOLOSYM_SIZE_MISMATCH, HOLOSYM_NONFINITE_VALUE, &
        HOLOSYM_RANK_DEFICIENT_CONSTRAINTS
    implicit none
    private

    public :: tangent_constraints, tangent_residual, project_tangent, tangent_basis

    !> Largest `tangent_residual` of a direction that `step_tangent` accepts: about
    !! epsilon^(3/4), 2^(-3(p-1)/4) for p binary digits (5e-26 in real128, 2e-12 in real64;
    !! an integer power, which every compiler folds). A direction built in the tangent space
    !! carries a residual of a few epsilon, and the tangent map adds about epsilon per step
    !! (1e6 steps stay near 1e6 epsilon, far below); a direction not built in it has a
    !! residual of order 1.
    real(wp), parameter, public :: tangent_tolerance = &
        2.0_wp**(-(3 * (digits(1.0_wp) - 1)) / 4)

contains

    !> The matrix C (2m x 2n) of the tangent space at (q, p); `finite` is false when a
    !! procedure of the system returned a non-finite value.
    subroutine tangent_constraints(sys, q, p, c, finite)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:), p(:)        !! the state (n each)
        real(wp), intent(out) :: c(:, :)          !! 2m x 2n
        logical, intent(out) :: finite            !! all values finite
        real(wp) :: phi_jac(sys%m, sys%n), phi_hess(sys%n, sys%n, sys%m), hp(sys%n)
        real(wp) :: hqq(sys%n, sys%n), hqp(sys%n, sys%n), hpp(sys%n, sys%n)
        integer :: l, m, n
        m = sys%m
        n = sys%n
        c = 0
        finite = .true.
        if (m == 0) return
        call sys%constraint_jacobian(q, phi_jac)
        call sys%constraint_hessian(q, phi_hess)
        call sys%dh_dp(q, p, hp)
        call sys%hessian(q, p, hqq, hqp, hpp)
        finite = all(is_finite(phi_jac)) .and. all(is_finite(phi_hess)) .and. &
            all(is_finite(hp)) .and. all(is_finite(hqp)) .and. all(is_finite(hpp))
        if (.not. finite) return
        c(1:m, 1:n) = phi_jac
        c(m + 1:2 * m, 1:n) = matmul(phi_jac, transpose(hqp))
        do l = 1, m
            c(m + l, 1:n) = c(m + l, 1:n) + matmul(hp, phi_hess(:, :, l))
        end do
        c(m + 1:2 * m, n + 1:2 * n) = matmul(phi_jac, hpp)
    end subroutine tangent_constraints

    !> How far the direction (dq, dp) is from the tangent space at (q, p): the largest
    !! |(C d)_l| / (sum_k |C_lk| max_k |d_k|) over the 2m rows of C (0 for d = 0), a
    !! number of the order of epsilon for a tangent direction and of order 1 for a generic
    !! one, whatever the sizes of d and of the rows (a row's entries that round-off left
    !! tiny do not make it large, as |(C d)_l| / sum_k |C_lk| |d_k| would). NaN when the system returns a non-finite value.
    function tangent_residual(sys, q, p, dq, dp) result(residual)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:), p(:)   !! the state (n each)
        real(wp), intent(in) :: dq(:), dp(:) !! the direction (n each)
        real(wp) :: residual
        real(wp) :: c(2 * sys%m, 2 * sys%n), d(2 * sys%n), product, scale
        logical :: finite
        integer :: l
        residual = 0
        call tangent_constraints(sys, q, p, c, finite)
        if (.not. (finite .and. all(is_finite(dq)) .and. all(is_finite(dp)))) then
            residual = ieee_value(residual, ieee_quiet_nan)
            return
        end if
        d(1:sys%n) = dq
        d(sys%n + 1:) = dp
        do l = 1, 2 * sys%m
            product = dot_product(c(l, :), d)
            scale = sum(abs(c(l, :))) * maxval(abs(d))
            if (scale > 0) residual = max(residual, abs(product) / scale)
        end do
    end function tangent_residual

    !> Project the directions (dq(:, k), dp(:, k)) orthogonally onto the tangent space at
    !! (q, p) (twice, so that the result is tangent to round-off): d <- d - C^T (C C^T)^-1 C d.
    !! HOLOSYM_SIZE_MISMATCH for arrays of the wrong shape, HOLOSYM_NONFINITE_VALUE when the
    !! system returns a non-finite value, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS when C has not
    !! full row rank; then dq and dp are unchanged.
    subroutine project_tangent(sys, q, p, dq, dp, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:), p(:)        !! the state (n each)
        real(wp), intent(inout) :: dq(:, :)       !! n x k directions of q
        real(wp), intent(inout) :: dp(:, :)       !! n x k directions of p
        type(holosym_status_t), intent(out), optional :: status !! outcome
        real(wp) :: c(2 * sys%m, 2 * sys%n), gram(2 * sys%m, 2 * sys%m), d(2 * sys%n)
        real(wp) :: y(2 * sys%m, 1)
        integer :: pivots(2 * sys%m), info, k, pass, n
        logical :: finite
        n = sys%n
        if (size(q) /= n .or. size(p) /= n .or. size(dq, 1) /= n .or. size(dp, 1) /= n .or. &
            size(dq, 2) /= size(dp, 2)) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "project_tangent: q, p need n = " &
                // int_str(n) // " entries, dq and dp n rows and the same number of columns")
            return
        end if
        call tangent_constraints(sys, q, p, c, finite)
        if (.not. (finite .and. all(is_finite(dq)) .and. all(is_finite(dp)))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "project_tangent: a direction " &
                // "or a derivative of the system at the state is not finite")
            return
        end if
        if (sys%m > 0) then
            gram = matmul(c, transpose(c))
            call lu_factor(gram, pivots, info)
            if (info /= 0) then
                call set_status(status, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, "project_tangent: " &
                    // "the constraints and hidden constraints are dependent at the state")
                return
            end if
            do k = 1, size(dq, 2)
                d(1:n) = dq(:, k)
                d(n + 1:) = dp(:, k)
                do pass = 1, 2
                    y(:, 1) = matmul(c, d)
                    call lu_solve(gram, pivots, y)
                    d = d - matmul(y(:, 1), c)
                end do
                dq(:, k) = d(1:n)
                dp(:, k) = d(n + 1:)
            end do
        end if
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine project_tangent

    !> An orthonormal basis of the tangent space at (q, p): its dimension 2(n - m) in
    !! `count`, the vectors in the first `count` columns of (dq, dp) (the unit vectors
    !! projected by `project_tangent`, orthonormalised by Gram-Schmidt twice, those that
    !! the projection leaves shorter than 1/10 after orthogonalisation dropped); the other
    !! columns zero. Codes as `project_tangent`; HOLOSYM_SIZE_MISMATCH also when dq or dp
    !! has fewer than 2(n - m) columns.
    subroutine tangent_basis(sys, q, p, dq, dp, count, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:), p(:)  !! the state (n each)
        real(wp), intent(out) :: dq(:, :)   !! n x (>= 2(n - m)) q parts of the basis
        real(wp), intent(out) :: dp(:, :)   !! n x (>= 2(n - m)) p parts of the basis
        integer, intent(out) :: count       !! 2(n - m), the vectors found
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        real(wp) :: uq(sys%n, 2 * sys%n), up(sys%n, 2 * sys%n), basis(2 * sys%n, 2 * sys%n)
        real(wp) :: v(2 * sys%n)
        integer :: k, j, n, pass
        n = sys%n
        count = 0
        dq = 0
        dp = 0
        if (size(dq, 2) < 2 * (n - sys%m) .or. size(dp, 2) /= size(dq, 2)) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "tangent_basis: dq and dp need " &
                // int_str(2 * (n - sys%m)) // " columns alike")
            return
        end if
        uq = 0
        up = 0
        do k = 1, n
            uq(k, k) = 1
            up(k, n + k) = 1
        end do
        call project_tangent(sys, q, p, uq, up, local)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        do k = 1, 2 * n
            if (count == 2 * (n - sys%m)) exit
            v(1:n) = uq(:, k)
            v(n + 1:) = up(:, k)
            do pass = 1, 2
                do j = 1, count
                    v = v - dot_product(basis(:, j), v) * basis(:, j)
                end do
                if (norm2(v) < 0.1_wp) exit
                v = v / norm2(v)
            end do
            if (pass <= 2) cycle
            count = count + 1
            basis(:, count) = v
        end do
        if (count < 2 * (n - sys%m)) then
            call set_status(status, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, "tangent_basis: " &
                // "the tangent space at the state has fewer than 2(n - m) dimensions")
            count = 0
            return
        end if
        dq(:, 1:count) = basis(1:n, 1:count)
        dp(:, 1:count) = basis(n + 1:, 1:count)
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine tangent_basis

end module holosym_tangent_space
