!> category: internal module (use holosym)
!! The step equations of the general scheme (`holosym_scheme`) differentiated along a
!! direction of all their variables: the nodes q_0..q_M (q_0 = q_a included), the momenta
!! p_0..p_N and the scaled multipliers mu_0..mu_M = h lambda. With the second derivatives
!! of H at the Gauss points, of phi at the nodes and of H at the step end, this is the
!! exact Jacobian-vector product of the residual (rows where `scheme_layout_t` puts them)
!! and of p_b = D_M, the two things the tangent map of a step needs:
!!
!!   dQ_g = sum_i B_gi dq_i,  dV_g = sum_i A_gi dq_i,  dP_g = sum_j C_gj dp_j,
!!   d(R_p,j) = sum_g w_g C_gj (dV_g - h (Hqp_g^T dQ_g + Hpp_g dP_g)),
!!   dD_i = sum_g w_g (A_gi dP_g - h B_gi (Hqq_g dQ_g + Hqp_g dP_g))
!!          - wl_i (sum_l mu_il phi_l''(q_i) dq_i + Phi_i^T dmu_i),
!!   d(phi(q_i)) = Phi_i dq_i,
!!   d(Phi_M H_p(q_M, D_M))_l = (phi_l''(q_M) dq_M) . H_p + Phi_M,l (Hqp_end^T dq_M
!!          + Hpp_end dD_M).
!!
!! The explicit p_a of the row p_a + D_0 is not a variable here (the caller adds it).
!! Written once from the formulas of docs/method.md, independently of the assembly of the
!! Newton matrix, which the test suite compares it with.
module holosym_scheme_linearised
    use holosym_kinds, only: wp
    use holosym_scheme_layout, only: scheme_layout_t
    implicit none
    private

    public :: linearised_inputs_t, linearised_residual

    !> What the derivative needs at one solution x of a step: the basis tables, the
    !! second derivatives and the constraint Jacobians. Sizes: n coordinates, m
    !! constraints, G Gauss points, (M, N) the orders.
    type :: linearised_inputs_t
        real(wp) :: h = 0                          !! step size
        real(wp), allocatable :: b(:, :)           !! (G, 0:M) rho_i(tau_g)
        real(wp), allocatable :: a(:, :)           !! (G, 0:M) rho_i'(tau_g)
        real(wp), allocatable :: c(:, :)           !! (G, 0:N) chi_j(tau_g)
        real(wp), allocatable :: w(:)              !! (G) Gauss weights
        real(wp), allocatable :: lobatto_weights(:) !! (0:M)
        real(wp), allocatable :: hqq(:, :, :)      !! (n, n, G) d2H/dq dq at Q_g, P_g
        real(wp), allocatable :: hqp(:, :, :)      !! (n, n, G) d2H/dq_a dp_b
        real(wp), allocatable :: hpp(:, :, :)      !! (n, n, G) d2H/dp dp
        real(wp), allocatable :: phi_hess(:, :, :, :) !! (n, n, m, 0:M) phi_l'' at q_i
        real(wp), allocatable :: phi_jac(:, :, :)  !! (m, n, 0:M) Phi at q_i
        real(wp), allocatable :: mu(:, :)          !! (m, 0:M) h lambda_i
        real(wp), allocatable :: velocity(:)       !! (n) H_p(q_M, p_b)
        real(wp), allocatable :: end_hqp(:, :)     !! (n, n) at (q_M, p_b)
        real(wp), allocatable :: end_hpp(:, :)     !! (n, n) at (q_M, p_b)
    end type linearised_inputs_t

contains

    !> The derivative of the residual rows (f, in the layout's row order) and of
    !! p_b = D_M (d_end) along (dq, dp, dmu).
    pure subroutine linearised_residual(s, lay, dq, dp, dmu, f, d_end)
        type(linearised_inputs_t), intent(in) :: s !! values at the solution
        type(scheme_layout_t), intent(in) :: lay   !! where the rows are
        real(wp), intent(in) :: dq(:, 0:)          !! (n, 0:M) directions of q_0..q_M
        real(wp), intent(in) :: dp(:, 0:)          !! (n, 0:N) directions of p_0..p_N
        real(wp), intent(in) :: dmu(:, 0:)         !! (m, 0:M) directions of mu_0..mu_M
        real(wp), intent(out) :: f(:)              !! (nx) derivative of the residual
        real(wp), intent(out) :: d_end(:)          !! (n) derivative of p_b = D_M
        real(wp) :: dd(lay%n, 0:lay%order_m), dq_g(lay%n), dv_g(lay%n), dp_g(lay%n)
        real(wp) :: dhq(lay%n), dhp(lay%n)
        integer :: g, i, j, l, n, m, order_m, row
        n = lay%n
        m = lay%m
        order_m = lay%order_m
        f = 0
        dd = 0
        do g = 1, size(s%w)
            dq_g = matmul(dq, s%b(g, :))
            dv_g = matmul(dq, s%a(g, :))
            dp_g = matmul(dp, s%c(g, :))
            dhq = matmul(s%hqq(:, :, g), dq_g) + matmul(s%hqp(:, :, g), dp_g)
            dhp = matmul(dq_g, s%hqp(:, :, g)) + matmul(s%hpp(:, :, g), dp_g)
            do j = 0, lay%order_n
                row = lay%rp_row_at(j)
                f(row + 1:row + n) = f(row + 1:row + n) + s%w(g) * s%c(g, j) * (dv_g - s%h * dhp)
            end do
            do i = 0, order_m
                dd(:, i) = dd(:, i) + s%w(g) * (s%a(g, i) * dp_g - s%h * s%b(g, i) * dhq)
            end do
        end do
        do i = 0, order_m
            do l = 1, m
                dd(:, i) = dd(:, i) - s%lobatto_weights(i) * (s%mu(l, i) * &
                    matmul(s%phi_hess(:, :, l, i), dq(:, i)) + s%phi_jac(l, :, i) * dmu(l, i))
            end do
        end do
        do i = 0, order_m - 1
            row = lay%d_row_at(i)
            f(row + 1:row + n) = dd(:, i)
        end do
        d_end = dd(:, order_m)
        do i = 1, order_m
            row = lay%phi_row_at(i)
            f(row + 1:row + m) = matmul(s%phi_jac(:, :, i), dq(:, i))
        end do
        if (m == 0) return
        row = lay%v_row_at
        dhp = matmul(dq(:, order_m), s%end_hqp) + matmul(s%end_hpp, d_end)
        do l = 1, m
            f(row + l) = dot_product(matmul(s%phi_hess(:, :, l, order_m), dq(:, order_m)), &
                                     s%velocity) + dot_product(s%phi_jac(l, :, order_m), dhp)
        end do
    end subroutine linearised_residual

end module holosym_scheme_linearised
