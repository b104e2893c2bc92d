!> The discrete scheme of one step (q_a, p_a) -> (q_b, p_b) for given (M, N, G):
!! precomputed quadrature and basis matrices, and the residual and Jacobian of the
!! nonlinear system of method.md section 3.
!!
!! Unknowns x, in increments so that step results are summed without cancellation:
!!   z_i = q_i - q_a (i = 1..M),  w_j = p_j - p_a (j = 0..N),  mu_k = h lambda_k (k = 0..M).
!! Equations (rows, in order): R_p,j (j = 0..N); D_i (i = 1..M-1); p_a + D_0;
!! phi(q_i) (i = 1..M); Phi(q_M) H_p(q_M, D_M), where
!!   D_i = sum_g w_g [A_gi P_g - h B_gi H_q(Q_g, P_g)] - wl_i Phi(q_i)^T mu_i.
module holosym_scheme
    use holosym_kinds, only: wp
    use holosym_status, only: holosym_status_t, set_status, int_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, HOLOSYM_NONFINITE_VALUE
    use holosym_quadrature, only: gauss_legendre, gauss_lobatto
    use holosym_lagrange, only: lagrange_values, lagrange_matrices
    use holosym_problem, only: constrained_hamiltonian
    use holosym_newton, only: nonlinear_system
    implicit none
    private

    public :: discrete_scheme, unknown_count

    !> The scheme for one (M, N, G) and one problem size (n, m), with its workspace.
    !! Before a Newton solve, `set_step` binds the system, the start state and h.
    type, extends(nonlinear_system), public :: discrete_scheme
        integer :: order_m = 0       !! M, degree of the displacement polynomial
        integer :: order_n = 0       !! N, degree of the momentum polynomial
        integer :: gauss_points = 0  !! G, Gauss-Legendre points for the Hamiltonian term
        integer :: n = 0             !! coordinates
        integer :: m = 0             !! constraints
        integer :: nx = 0            !! unknowns = equations
        real(wp), allocatable :: disp_nodes(:)      !! d_0..d_M, Lobatto points
        real(wp), allocatable :: lobatto_weights(:) !! wl_0..wl_M
        real(wp), allocatable :: mom_nodes(:)       !! c_0..c_N
        real(wp), allocatable :: gauss_nodes(:)     !! tau_1..tau_G
        real(wp), allocatable :: gauss_weights(:)   !! w_1..w_G
        real(wp), allocatable :: b(:, :)  !! B(g, i) = rho_i(tau_g), G x (0:M)
        real(wp), allocatable :: a(:, :)  !! A(g, i) = rho_i'(tau_g), G x (0:M)
        real(wp), allocatable :: c(:, :)  !! C(g, j) = chi_j(tau_g), G x (0:N)
        ! Step context (valid during one solve).
        class(constrained_hamiltonian), pointer, private :: sys => null()
        real(wp), allocatable, private :: qa(:), pa(:)
        real(wp), private :: h = 0
        ! Workspace of the last evaluation, reused by the Jacobian at the same x.
        real(wp), allocatable, private :: cached_x(:)
        logical, private :: cache_valid = .false.
        real(wp), allocatable, private :: q_nodes(:, :)      ! n x (0:M)
        real(wp), allocatable, private :: q_gauss(:, :)      ! n x G
        real(wp), allocatable, private :: v_gauss(:, :)      ! n x G
        real(wp), allocatable, private :: p_gauss(:, :)      ! n x G
        real(wp), allocatable, private :: hq_gauss(:, :)     ! n x G
        real(wp), allocatable, private :: hp_gauss(:, :)     ! n x G
        real(wp), allocatable, private :: phi_jac(:, :, :)   ! m x n x (0:M)
        real(wp), allocatable, private :: d_values(:, :)     ! n x (0:M)
    contains
        !> Set up the scheme for (M, N, G) and sizes (n, m).
        procedure :: init => scheme_init
        !> Bind the system, start state and step size for the next solve.
        procedure :: set_step => scheme_set_step
        !> Residual of the step equations.
        procedure :: residual => scheme_residual
        !> Jacobian of the step equations.
        procedure :: jacobian => scheme_jacobian
        !> The trivial first guess (q_i = q_a, p_j = p_a, lambda = 0).
        procedure :: constant_guess => scheme_constant_guess
        !> First guess from the previous step's polynomials, extrapolated.
        procedure :: extrapolated_guess => scheme_extrapolated_guess
        !> Step results (q_b - q_a, p_b - p_a) from a solution.
        procedure :: increments => scheme_increments
        !> Polynomials q~, p~, lambda~ of a solved step at tau.
        procedure :: dense => scheme_dense
        !> Multipliers lambda_k at the displacement nodes and max |phi| over the nodes.
        procedure :: node_values => scheme_node_values
    end type discrete_scheme

contains

    !> Number of unknowns (= equations) of one step: (M+N+1) n + (M+1) m.
    pure integer function unknown_count(order_m, order_n, n, m)
        integer, intent(in) :: order_m !! M
        integer, intent(in) :: order_n !! N
        integer, intent(in) :: n       !! coordinates
        integer, intent(in) :: m       !! constraints
        unknown_count = (order_m + order_n + 1) * n + (order_m + 1) * m
    end function unknown_count

    !> Set up nodes, weights and basis matrices for (M, N, G) and the sizes (n, m).
    !! Codes: HOLOSYM_INVALID_ORDER (M < 1, N < 0, G < 1), HOLOSYM_INVALID_DIMENSION.
    subroutine scheme_init(self, order_m, order_n, gauss_points, n, m, status)
        class(discrete_scheme), intent(inout) :: self
        integer, intent(in) :: order_m      !! M >= 1
        integer, intent(in) :: order_n      !! N >= 0
        integer, intent(in) :: gauss_points !! G >= 1
        integer, intent(in) :: n            !! coordinates, >= 1
        integer, intent(in) :: m            !! constraints, 0 <= m < n
        type(holosym_status_t), intent(out), optional :: status !! outcome
        real(wp), allocatable :: unused(:, :), mom_weights(:)

        if (order_m < 1 .or. order_n < 0 .or. gauss_points < 1) then
            call set_status(status, HOLOSYM_INVALID_ORDER, "need M >= 1, N >= 0, G >= 1; got M = " &
                // int_str(order_m) // ", N = " // int_str(order_n) // ", G = " // int_str(gauss_points))
            return
        end if
        if (n < 1 .or. m < 0 .or. m >= n) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "need n >= 1 and 0 <= m < n; got n = " &
                // int_str(n) // ", m = " // int_str(m))
            return
        end if
        ! A scheme may be set up again for other orders or sizes: start from scratch.
        call release(self)
        self%order_m = order_m
        self%order_n = order_n
        self%gauss_points = gauss_points
        self%n = n
        self%m = m
        self%nx = unknown_count(order_m, order_n, n, m)

        allocate (self%disp_nodes(0:order_m), self%lobatto_weights(0:order_m))
        call gauss_lobatto(self%disp_nodes, self%lobatto_weights)
        allocate (self%mom_nodes(0:order_n))
        if (order_n == 0) then
            self%mom_nodes(0) = 0.5_wp
        else
            allocate (mom_weights(0:order_n))
            call gauss_lobatto(self%mom_nodes, mom_weights)
        end if
        allocate (self%gauss_nodes(gauss_points), self%gauss_weights(gauss_points))
        call gauss_legendre(self%gauss_nodes, self%gauss_weights)

        allocate (self%b(gauss_points, 0:order_m), self%a(gauss_points, 0:order_m))
        allocate (self%c(gauss_points, 0:order_n), unused(gauss_points, 0:order_n))
        call lagrange_matrices(self%disp_nodes, self%gauss_nodes, self%b, self%a)
        call lagrange_matrices(self%mom_nodes, self%gauss_nodes, self%c, unused)

        allocate (self%qa(n), self%pa(n), self%cached_x(self%nx))
        allocate (self%q_nodes(n, 0:order_m), self%d_values(n, 0:order_m))
        allocate (self%q_gauss(n, gauss_points), self%v_gauss(n, gauss_points))
        allocate (self%p_gauss(n, gauss_points), self%hq_gauss(n, gauss_points))
        allocate (self%hp_gauss(n, gauss_points), self%phi_jac(m, n, 0:order_m))
        self%cache_valid = .false.
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine scheme_init

    !> Deallocate every array component (before a new `init`).
    subroutine release(self)
        class(discrete_scheme), intent(inout) :: self
        if (allocated(self%disp_nodes)) deallocate (self%disp_nodes, self%lobatto_weights, &
            self%mom_nodes, self%gauss_nodes, self%gauss_weights, self%b, self%a, self%c, &
            self%qa, self%pa, self%cached_x, self%q_nodes, self%d_values, self%q_gauss, &
            self%v_gauss, self%p_gauss, self%hq_gauss, self%hp_gauss, self%phi_jac)
        self%cache_valid = .false.
    end subroutine release

    !> Bind the system, the start state (q_a, p_a) and h for the next solve. The system
    !! must stay alive and unchanged until the solve and its follow-up calls are done.
    subroutine scheme_set_step(self, sys, qa, pa, h)
        class(discrete_scheme), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys !! the problem
        real(wp), intent(in) :: qa(:) !! start coordinates (n)
        real(wp), intent(in) :: pa(:) !! start momenta (n)
        real(wp), intent(in) :: h     !! step size
        self%sys => sys
        self%qa = qa
        self%pa = pa
        self%h = h
        self%cache_valid = .false.
    end subroutine scheme_set_step

    !> Offset (0-based) of unknown block z_k, k = 1..M.
    pure integer function z_at(self, k)
        class(discrete_scheme), intent(in) :: self
        integer, intent(in) :: k
        z_at = (k - 1) * self%n
    end function z_at

    !> Offset of unknown block w_j, j = 0..N.
    pure integer function w_at(self, j)
        class(discrete_scheme), intent(in) :: self
        integer, intent(in) :: j
        w_at = (self%order_m + j) * self%n
    end function w_at

    !> Offset of unknown block mu_k, k = 0..M.
    pure integer function mu_at(self, k)
        class(discrete_scheme), intent(in) :: self
        integer, intent(in) :: k
        mu_at = (self%order_m + self%order_n + 1) * self%n + k * self%m
    end function mu_at

    !> Offset of the row block D_i: i = 0 is p_a + D_0, i = 1..M-1 the interior equations.
    pure integer function d_row_at(self, i)
        class(discrete_scheme), intent(in) :: self
        integer, intent(in) :: i
        if (i == 0) then
            d_row_at = (self%order_n + self%order_m) * self%n
        else
            d_row_at = (self%order_n + i) * self%n
        end if
    end function d_row_at

    !> Evaluate the polynomials and the user's first derivatives at x (cached).
    subroutine evaluate(self, x, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        type(holosym_status_t), intent(out) :: status
        integer :: n, m, g, i, j
        real(wp) :: mu(self%m)

        if (self%cache_valid) then
            if (all(x == self%cached_x)) then
                call set_status(status, HOLOSYM_SUCCESS, "")
                return
            end if
        end if
        self%cache_valid = .false.
        n = self%n
        m = self%m
        self%q_nodes(:, 0) = self%qa
        do i = 1, self%order_m
            self%q_nodes(:, i) = self%qa + x(z_at(self, i) + 1:z_at(self, i) + n)
        end do
        do g = 1, self%gauss_points
            self%q_gauss(:, g) = self%qa
            self%v_gauss(:, g) = 0
            do i = 1, self%order_m
                self%q_gauss(:, g) = self%q_gauss(:, g) + self%b(g, i) * x(z_at(self, i) + 1:z_at(self, i) + n)
                self%v_gauss(:, g) = self%v_gauss(:, g) + self%a(g, i) * x(z_at(self, i) + 1:z_at(self, i) + n)
            end do
            self%p_gauss(:, g) = self%pa
            do j = 0, self%order_n
                self%p_gauss(:, g) = self%p_gauss(:, g) + self%c(g, j) * x(w_at(self, j) + 1:w_at(self, j) + n)
            end do
            call self%sys%dh_dq(self%q_gauss(:, g), self%p_gauss(:, g), self%hq_gauss(:, g))
            call self%sys%dh_dp(self%q_gauss(:, g), self%p_gauss(:, g), self%hp_gauss(:, g))
            if (.not. (all(is_finite(self%hq_gauss(:, g))) .and. all(is_finite(self%hp_gauss(:, g))))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "dh_dq or dh_dp returned a " // &
                    "non-finite value at Gauss point " // int_str(g))
                return
            end if
        end do
        do i = 0, self%order_m
            call self%sys%constraint_jacobian(self%q_nodes(:, i), self%phi_jac(:, :, i))
            if (.not. all(is_finite(self%phi_jac(:, :, i)))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint_jacobian returned " // &
                    "a non-finite value at displacement node " // int_str(i))
                return
            end if
        end do
        do i = 0, self%order_m
            mu = x(mu_at(self, i) + 1:mu_at(self, i) + m)
            self%d_values(:, i) = -self%lobatto_weights(i) * matmul(mu, self%phi_jac(:, :, i))
            do g = 1, self%gauss_points
                self%d_values(:, i) = self%d_values(:, i) + self%gauss_weights(g) * &
                    (self%a(g, i) * self%p_gauss(:, g) - self%h * self%b(g, i) * self%hq_gauss(:, g))
            end do
        end do
        self%cached_x = x
        self%cache_valid = .true.
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine evaluate

    !> Residual of the step equations at x (see the module header for the row order).
    subroutine scheme_residual(self, x, f, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)   !! unknowns
        real(wp), intent(out) :: f(:)  !! residual
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        integer :: n, m, g, i, j, row
        real(wp) :: velocity(self%n)

        call evaluate(self, x, status)
        if (.not. status%ok()) return
        n = self%n
        m = self%m
        do j = 0, self%order_n
            row = j * n
            f(row + 1:row + n) = 0
            do g = 1, self%gauss_points
                f(row + 1:row + n) = f(row + 1:row + n) + self%gauss_weights(g) * self%c(g, j) * &
                    (self%v_gauss(:, g) - self%h * self%hp_gauss(:, g))
            end do
        end do
        do i = 1, self%order_m - 1
            row = d_row_at(self, i)
            f(row + 1:row + n) = self%d_values(:, i)
        end do
        row = d_row_at(self, 0)
        f(row + 1:row + n) = self%pa + self%d_values(:, 0)
        row = (self%order_m + self%order_n + 1) * n
        do i = 1, self%order_m
            call self%sys%constraint(self%q_nodes(:, i), f(row + 1:row + m))
            row = row + m
        end do
        call self%sys%dh_dp(self%q_nodes(:, self%order_m), self%d_values(:, self%order_m), velocity)
        f(row + 1:row + m) = matmul(self%phi_jac(:, :, self%order_m), velocity)
        if (.not. all(is_finite(f))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint or dh_dp returned a " // &
                "non-finite value at a displacement node")
        end if
    end subroutine scheme_residual

    !> Jacobian of the step equations at x, assembled from the second derivatives of H
    !! and phi (the system's own, or its finite-difference defaults).
    subroutine scheme_jacobian(self, x, jac, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)        !! unknowns
        real(wp), intent(out) :: jac(:, :)  !! nx x nx
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        integer :: n, m, mm, g, i, j, k, l, row, col
        real(wp), allocatable :: hqq(:, :, :), hqp(:, :, :), hpp(:, :, :), phi_hess(:, :, :, :)
        real(wp), allocatable :: d_block(:, :), end_hqq(:, :), end_hqp(:, :), end_hpp(:, :)
        real(wp) :: weight, identity(self%n, self%n), velocity(self%n), mu(self%m)

        call evaluate(self, x, status)
        if (.not. status%ok()) return
        n = self%n
        m = self%m
        mm = self%order_m
        allocate (hqq(n, n, self%gauss_points), hqp(n, n, self%gauss_points), &
                  hpp(n, n, self%gauss_points), phi_hess(n, n, m, 1:mm), d_block(n, self%nx), &
                  end_hqq(n, n), end_hqp(n, n), end_hpp(n, n))
        identity = 0
        do i = 1, n
            identity(i, i) = 1
        end do
        do g = 1, self%gauss_points
            call self%sys%hessian(self%q_gauss(:, g), self%p_gauss(:, g), hqq(:, :, g), &
                                  hqp(:, :, g), hpp(:, :, g))
        end do
        do i = 1, mm
            call self%sys%constraint_hessian(self%q_nodes(:, i), phi_hess(:, :, :, i))
        end do
        if (.not. (all(is_finite(hqq)) .and. all(is_finite(hqp)) .and. all(is_finite(hpp)) .and. &
                   all(is_finite(phi_hess)))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "second derivatives of H or phi " // &
                "are not finite")
            return
        end if

        jac = 0
        ! R_p,j = sum_g w_g C_gj (V_g - h H_p): depends on z (through Q, V) and w (through P).
        do j = 0, self%order_n
            row = j * n
            do k = 1, mm
                col = z_at(self, k)
                do g = 1, self%gauss_points
                    weight = self%gauss_weights(g) * self%c(g, j)
                    jac(row + 1:row + n, col + 1:col + n) = jac(row + 1:row + n, col + 1:col + n) &
                        + weight * (self%a(g, k) * identity &
                                    - self%h * self%b(g, k) * transpose(hqp(:, :, g)))
                end do
            end do
            do l = 0, self%order_n
                col = w_at(self, l)
                do g = 1, self%gauss_points
                    weight = -self%h * self%gauss_weights(g) * self%c(g, j) * self%c(g, l)
                    jac(row + 1:row + n, col + 1:col + n) = jac(row + 1:row + n, col + 1:col + n) &
                        + weight * hpp(:, :, g)
                end do
            end do
        end do
        ! D_i rows for i = 0..M-1; D_M feeds the velocity constraint below.
        do i = 0, mm
            d_block = 0
            do k = 1, mm
                col = z_at(self, k)
                do g = 1, self%gauss_points
                    weight = -self%h * self%gauss_weights(g) * self%b(g, i) * self%b(g, k)
                    d_block(:, col + 1:col + n) = d_block(:, col + 1:col + n) + weight * hqq(:, :, g)
                end do
            end do
            if (i >= 1) then
                col = z_at(self, i)
                mu = x(mu_at(self, i) + 1:mu_at(self, i) + m)
                do l = 1, m
                    d_block(:, col + 1:col + n) = d_block(:, col + 1:col + n) &
                        - self%lobatto_weights(i) * mu(l) * phi_hess(:, :, l, i)
                end do
            end if
            do l = 0, self%order_n
                col = w_at(self, l)
                do g = 1, self%gauss_points
                    weight = self%gauss_weights(g) * self%c(g, l)
                    d_block(:, col + 1:col + n) = d_block(:, col + 1:col + n) &
                        + weight * (self%a(g, i) * identity - self%h * self%b(g, i) * hqp(:, :, g))
                end do
            end do
            col = mu_at(self, i)
            d_block(:, col + 1:col + m) = -self%lobatto_weights(i) * transpose(self%phi_jac(:, :, i))
            if (i < mm) then
                row = d_row_at(self, i)
                jac(row + 1:row + n, :) = d_block
            end if
        end do
        ! phi(q_i) rows.
        row = (mm + self%order_n + 1) * n
        do i = 1, mm
            col = z_at(self, i)
            jac(row + 1:row + m, col + 1:col + n) = self%phi_jac(:, :, i)
            row = row + m
        end do
        ! Phi(q_M) H_p(q_M, p_b), p_b = D_M: chain rule through D_M (d_block holds dD_M/dx).
        call self%sys%dh_dp(self%q_nodes(:, mm), self%d_values(:, mm), velocity)
        call self%sys%hessian(self%q_nodes(:, mm), self%d_values(:, mm), end_hqq, end_hqp, end_hpp)
        if (.not. (all(is_finite(velocity)) .and. all(is_finite(end_hqp)) .and. &
                   all(is_finite(end_hpp)))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "dh_dp or its derivatives are not " // &
                "finite at the step end")
            return
        end if
        jac(row + 1:row + m, :) = matmul(matmul(self%phi_jac(:, :, mm), end_hpp), d_block)
        col = z_at(self, mm)
        jac(row + 1:row + m, col + 1:col + n) = jac(row + 1:row + m, col + 1:col + n) &
            + matmul(self%phi_jac(:, :, mm), transpose(end_hqp))
        do l = 1, m
            jac(row + l, col + 1:col + n) = jac(row + l, col + 1:col + n) &
                + matmul(phi_hess(:, :, l, mm), velocity)
        end do
    end subroutine scheme_jacobian

    !> First guess q_i = q_a, p_j = p_a, lambda_k = 0 (all increments zero).
    pure subroutine scheme_constant_guess(self, x)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(out) :: x(:) !! unknowns (nx)
        x = 0
    end subroutine scheme_constant_guess

    !> First guess from a previous solved step (x_prev from (qa_prev, pa_prev) with h_prev):
    !! its polynomials evaluated beyond tau = 1 at the new step's nodes.
    subroutine scheme_extrapolated_guess(self, x_prev, qa_prev, pa_prev, h_prev, qa, pa, h, x)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: x_prev(:)  !! solution of the previous step
        real(wp), intent(in) :: qa_prev(:) !! its start coordinates
        real(wp), intent(in) :: pa_prev(:) !! its start momenta
        real(wp), intent(in) :: h_prev     !! its step size
        real(wp), intent(in) :: qa(:)      !! start coordinates of the new step
        real(wp), intent(in) :: pa(:)      !! start momenta of the new step
        real(wp), intent(in) :: h          !! new step size
        real(wp), intent(out) :: x(:)      !! first guess (nx)
        real(wp) :: q(self%n), p(self%n), lambda(self%m), ratio
        integer :: i, j, n, m
        n = self%n
        m = self%m
        ratio = h / h_prev
        do i = 0, self%order_m
            call self%dense(x_prev, qa_prev, pa_prev, h_prev, 1 + ratio * self%disp_nodes(i), &
                            q, p, lambda)
            if (i >= 1) x(z_at(self, i) + 1:z_at(self, i) + n) = q - qa
            x(mu_at(self, i) + 1:mu_at(self, i) + m) = h * lambda
        end do
        do j = 0, self%order_n
            call self%dense(x_prev, qa_prev, pa_prev, h_prev, 1 + ratio * self%mom_nodes(j), &
                            q, p, lambda)
            x(w_at(self, j) + 1:w_at(self, j) + n) = p - pa
        end do
    end subroutine scheme_extrapolated_guess

    !> Step results from the solution x of the step bound by `set_step`:
    !! dq = q_b - q_a = z_M and dp = p_b - p_a = sum_i D_i
    !!    = -h sum_g w_g H_q(Q_g, P_g) - sum_i wl_i Phi(q_i)^T mu_i
    !! (the sum avoids the cancellation in D_M - (-p_a)).
    subroutine scheme_increments(self, x, dq, dp, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)    !! solution
        real(wp), intent(out) :: dq(:)  !! q_b - q_a
        real(wp), intent(out) :: dp(:)  !! p_b - p_a
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        integer :: g, i
        call evaluate(self, x, status)
        if (.not. status%ok()) return
        dq = x(z_at(self, self%order_m) + 1:z_at(self, self%order_m) + self%n)
        dp = 0
        do g = 1, self%gauss_points
            dp = dp - self%h * self%gauss_weights(g) * self%hq_gauss(:, g)
        end do
        do i = 0, self%order_m
            dp = dp - self%lobatto_weights(i) * &
                matmul(x(mu_at(self, i) + 1:mu_at(self, i) + self%m), self%phi_jac(:, :, i))
        end do
    end subroutine scheme_increments

    !> Dense output of a solved step: q~(tau), p~(tau), lambda~(tau) for any tau
    !! (tau in [0, 1] interpolates; outside it extrapolates).
    pure subroutine scheme_dense(self, x, qa, pa, h, tau, q, p, lambda)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: x(:)   !! solution of the step
        real(wp), intent(in) :: qa(:)  !! its start coordinates
        real(wp), intent(in) :: pa(:)  !! its start momenta
        real(wp), intent(in) :: h      !! its step size
        real(wp), intent(in) :: tau    !! normalised time t/h
        real(wp), intent(out) :: q(:)       !! q~(tau)
        real(wp), intent(out) :: p(:)       !! p~(tau)
        real(wp), intent(out) :: lambda(:)  !! lambda~(tau)
        real(wp) :: rho(0:self%order_m), chi(0:self%order_n)
        integer :: i, j
        rho = lagrange_values(self%disp_nodes, tau)
        chi = lagrange_values(self%mom_nodes, tau)
        q = qa
        lambda = 0
        do i = 0, self%order_m
            if (i >= 1) q = q + rho(i) * x(z_at(self, i) + 1:z_at(self, i) + self%n)
            lambda = lambda + rho(i) * x(mu_at(self, i) + 1:mu_at(self, i) + self%m) / h
        end do
        p = pa
        do j = 0, self%order_n
            p = p + chi(j) * x(w_at(self, j) + 1:w_at(self, j) + self%n)
        end do
    end subroutine scheme_dense

    !> Multipliers at the displacement nodes and the largest |phi(q_i)|, i = 0..M.
    subroutine scheme_node_values(self, x, lambda, max_phi)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)            !! solution of the step bound by set_step
        real(wp), intent(out) :: lambda(:, 0:)  !! m x (0:M) multipliers lambda_k
        real(wp), intent(out) :: max_phi        !! max over nodes and components of |phi|
        real(wp) :: phi(self%m), q(self%n)
        integer :: i
        max_phi = 0
        do i = 0, self%order_m
            lambda(:, i) = x(mu_at(self, i) + 1:mu_at(self, i) + self%m) / self%h
            q = self%qa
            if (i >= 1) q = q + x(z_at(self, i) + 1:z_at(self, i) + self%n)
            call self%sys%constraint(q, phi)
            if (self%m > 0) max_phi = max(max_phi, maxval(abs(phi)))
        end do
    end subroutine scheme_node_values

end module holosym_scheme
