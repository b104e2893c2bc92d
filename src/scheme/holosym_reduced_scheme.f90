!> category: internal module (use holosym)
!! The reduced step equations: the scheme of `holosym_scheme` with the momenta eliminated,
!! for H = p^T M^-1 p / 2 + U(q) with a constant diagonal mass matrix M.
!!
!! The momentum equations R_p,j are then linear in the momentum nodes p_j: with
!! E = (C^T W C)^-1 C^T W A ((N+1) x (M+1), constant for (M, N, G)),
!!     p_j = (1/h) M sum_k E(j, k) z_k,        z_k = q_k - q_a,
!! and substituting them into D_i = dS~/dq_i gives, with S = A^T W C E,
!!     D_i = (1/h) M sum_k S(i, k) z_k - h sum_g w_g B(g, i) grad U(q~(tau_g))
!!           - wl_i Phi(q_i)^T mu_i,                         mu_i = h lambda_i.
!! (S 1 = 0 and E 1 = 0: the increments z_k carry no cancellation of q_a.)
!! Unknowns z_1..z_M and mu_0..mu_M, M n + (M + 1) m of them; equations
!! p_a + D_0 = 0, D_i = 0 (i = 1..M-1), phi(q_i) = 0 (i = 1..M) and
!! Phi(q_M) M^-1 D_M = 0 (the hidden constraint at p_b = D_M). The step returns
!! q_b - q_a = z_M and p_b - p_a = -h sum_g w_g grad U(q~(tau_g)) - sum_i wl_i Phi_i^T mu_i.
!! Their order in the unknown vector is the layout's (`holosym_reduced_layout`).
!!
!! The residual is evaluated in working precision or, for the first Newton iterations,
!! with its sums in real64 (`residual_dp`); the user's procedures always see
!! working-precision arguments. The Newton matrix (`form_jacobian`, real64, in the
!! layout's compressed-row pattern) is assembled from the second derivatives of U and phi
!! at the last evaluation's points: the system's Hessians, or differences of its
!! gradients along the colours of the coupling graph when a sparsity is declared.
!!
!! `reduced_equations` presents the scheme as a `nonlinear_system` (the interface of
!! `newton_solve`, which the general scheme implements too): `residual`, `jacobian` (the
!! Newton matrix as a dense working-precision matrix) and `residual_lowered` (the real64
!! sums). The reduced step (`holosym_reduced_step`) iterates the scheme with banded real64
!! factors; `newton_solve` can solve it as it solves the general scheme.
module holosym_reduced_scheme
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_NEWTON_DIVERGED
    use holosym_quadrature, only: gauss_legendre, gauss_lobatto
    use holosym_lagrange, only: lagrange_values, lagrange_matrices
    use holosym_linalg, only: lu_factor, lu_solve
    use holosym_problem, only: constrained_hamiltonian, refusal_pending, check_refusal
    use holosym_newton, only: all_finite
    use holosym_step_scheme, only: step_scheme, scheme_counters_t
    use holosym_factors, only: real64_factors_t
    use holosym_reduced_layout, only: reduced_layout_t
    use holosym_reduced_multipliers, only: multiplier_solve_t
    use holosym_reduced_kernels_dd, only: dd_tables_t, dd_tables_init, dd_step_tables, dd_fits, &
        dd_gauss_positions, dd_node_sums
    use holosym_reduced_kernels_wp, only: tables_wp => reduced_tables, &
        evaluation_wp => reduced_evaluation, allocate_evaluation_wp => allocate_evaluation, &
        gather_wp => gather_unknowns, positions_wp => gauss_positions, &
        forces_wp => multiplier_forces, sums_wp => node_sums, rows_wp => momentum_rows
    use holosym_reduced_kernels_dp, only: tables_dp => reduced_tables, &
        evaluation_dp => reduced_evaluation, allocate_evaluation_dp => allocate_evaluation, &
        gather_dp => gather_unknowns, positions_dp => gauss_positions, &
        forces_dp => multiplier_forces, sums_dp => node_sums, rows_dp => momentum_rows
    implicit none
    private

    public :: reduced_scheme_t, reduced_structure

    !> Relative step of the forward differences of second derivatives: sqrt(epsilon), whose
    !! error (about sqrt(epsilon) relative) is far below the real64 factors' round-off.
    real(wp), parameter :: difference_step = sqrt(epsilon(1.0_wp))

    !> The reduced equations for one (M, N, G) and one system, with their workspace.
    type :: reduced_scheme_t
        integer :: order_m = 0, order_n = 0, gauss_points = 0
        integer :: n = 0, m = 0, nx = 0
        !> Where unknowns and equations live, and the Newton matrix's pattern.
        type(reduced_layout_t) :: layout
        real(wp), allocatable :: disp_nodes(:)  !! d_0..d_M (Lobatto)
        real(wp), allocatable :: mom_nodes(:)   !! c_0..c_N
        real(wp), allocatable :: e(:, :)        !! E(j, k), (0:N, 1:M)
        !> rho_i(1 + d_k): extrapolation of the displacement polynomial to the next step.
        real(wp), allocatable :: extrap(:, :)   !! (0:M node k, 0:M basis i)
        !> Weights of z_k in h M^-1 p~(0) and h M^-1 p~(1): sum_j chi_j(0 or 1) E(j, k).
        real(wp), allocatable :: end_weights(:, :) !! (1:M, 2)
        real(wp), allocatable :: mass(:)        !! diagonal of M
        type(tables_wp) :: tab
        type(tables_dp) :: low_tab
        !> The last working-precision evaluation (at `x_eval`) and the lowered one.
        type(evaluation_wp) :: ev
        type(evaluation_dp) :: low
        real(wp), allocatable :: x_eval(:)
        logical :: have_eval = .false.
        ! Step context.
        class(constrained_hamiltonian), pointer :: sys => null()
        real(wp), allocatable :: qa(:), pa(:), mass_over_h(:), inv_mass(:)
        !> h w_g B(g, i) and h w_g of the step (working precision and real64).
        real(wp), allocatable :: hwb(:, :), hw(:)
        real(dp), allocatable :: low_hwb(:, :), low_hw(:)
        real(dp), allocatable :: low_qa(:), low_mass_over_h(:), low_inv_mass(:)
        real(wp) :: h = 0
        ! Workspace of the user calls.
        real(wp), allocatable :: q_work(:), g_work(:), pv_work(:)
        !> The points of a residual's batched user calls: the nodes q_a + z_i (n x M), phi
        !! and Phi's values there (m x M, nnz x M), zero momenta at the Gauss points (n x G;
        !! its first column the zero momentum of the calls at one point).
        real(wp), allocatable :: q_nodes(:, :), phi_nodes(:, :), pv_nodes(:, :), p_zeros(:, :)
        real(dp), allocatable :: low_p_zeros(:, :)
        !> The Newton matrix and d(p_b - p_a)/dx, values in the layout's patterns.
        real(dp), allocatable :: jac_values(:), dp_values(:)
        integer, allocatable :: position(:)   ! column -> entry of the open row (nx)
        real(dp), allocatable :: x_low(:), f_base(:)
        !> Second derivatives: U'' at the Gauss points and L_i at the nodes on the coupling
        !! pattern, d(Phi v)/dq on Phi's pattern (real64).
        real(dp), allocatable :: hu(:, :), lv(:, :), kv(:)
        !> U is linear in q (an empty Hessian pattern declared): no U'' at all.
        logical :: linear_potential = .false.
        ! Workspace of the second derivatives.
        real(wp), allocatable :: q_shift(:), steps(:), t_base(:), t_shift(:), mu_work(:)
        real(wp), allocatable :: pv_shift(:)
        real(wp), allocatable :: hqq(:, :), hqp(:, :), hpp(:, :), phi_hess(:, :, :)
        !> The iteration matrix without curvature (`holosym_reduced_multipliers`).
        type(multiplier_solve_t) :: fixed
        !> The inner sums of the working-precision residual in double-double arithmetic
        !! (`holosym_reduced_kernels_dd`): asked for this step (`set_step`), and the step's
        !! tables within their range.
        type(dd_tables_t) :: dd
        logical :: dd_step = .false.
        !> User calls of the evaluations (gradients of U, constraint values, Phi values);
        !! `paired_residuals` counts the residuals summed in double-double arithmetic.
        integer :: residuals = 0, lowered_residuals = 0, jacobians = 0, gradients = 0
        integer :: paired_residuals = 0
    contains
        procedure :: init => reduced_init
        procedure :: set_step => reduced_set_step
        procedure :: residual => reduced_residual
        procedure :: residual_dp => reduced_residual_dp
        procedure :: form_jacobian => reduced_form_jacobian
        procedure :: increments => reduced_increments
        procedure :: linear_dp_change => reduced_linear_dp_change
        procedure :: multiplier_dp_change => reduced_multiplier_dp_change
        procedure :: dense => reduced_dense
        procedure :: momentum_jump => reduced_momentum_jump
        procedure :: multipliers => reduced_multipliers
        procedure :: extrapolated_guess => reduced_extrapolated_guess
    end type reduced_scheme_t

    !> The reduced scheme as every scheme presents itself (`step_scheme`, which the
    !! general scheme implements too): point `scheme` at a set-up scheme. Newton's side
    !! (`residual`, `jacobian`: the Newton matrix as a dense working-precision matrix,
    !! `residual_lowered` and `residual_dp`: the real64 sums, `factor_matrix`: the banded
    !! real64 matrix) and the solved step's (`increments` from an evaluation at the
    !! solution, nodes, multipliers, momentum ends, dense output, work) are the scheme's.
    type, extends(step_scheme), public :: reduced_equations
        type(reduced_scheme_t), pointer :: scheme => null() !! the scheme, bound to a step
    contains
        procedure :: residual => equations_residual
        procedure :: jacobian => equations_jacobian
        procedure :: residual_lowered => equations_residual_lowered
        procedure :: residual_dp => equations_residual_dp
        procedure :: factor_matrix => equations_factor_matrix
        procedure :: factor_approximate => equations_factor_approximate
        procedure :: solve_approximate => equations_solve_approximate
        procedure :: unknowns => equations_unknowns
        procedure :: bind => equations_bind
        procedure :: constant_guess => equations_constant_guess
        procedure :: increments => equations_increments
        procedure :: solution_node => equations_solution_node
        procedure :: node_values => equations_node_values
        procedure :: momentum_jump => equations_momentum_jump
        procedure :: dense => equations_dense
        procedure :: work => equations_work
    end type reduced_equations

contains

    !> Whether a system declares the structure the reduced step needs (a constant diagonal
    !! mass matrix), and the masses.
    logical function reduced_structure(sys, mass)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(out) :: mass(:)                  !! diagonal of M (n)
        reduced_structure = sys%diagonal_mass(mass)
    end function reduced_structure

    !> Set up the reduced scheme for (M, N, G) and the system's sizes, mass matrix and
    !! sparsity. Codes: HOLOSYM_INVALID_ORDER (G < N + 1), HOLOSYM_INVALID_ARGUMENT (no mass
    !! matrix declared, a non-positive or non-finite mass, a pattern out of range).
    subroutine reduced_init(self, sys, order_m, order_n, gauss_points, status)
        class(reduced_scheme_t), intent(out) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        integer, intent(in) :: order_m, order_n, gauss_points !! M >= 1, N >= 0, G >= N + 1
        type(holosym_status_t), intent(out) :: status !! outcome
        integer, allocatable :: phi_rows(:), phi_cols(:), hess_rows(:), hess_cols(:)
        integer :: n, m

        n = sys%n
        m = sys%m
        if (allocated(self%mass)) deallocate (self%mass)
        allocate (self%mass(n))
        if (.not. reduced_structure(sys, self%mass)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "the system declares no " // &
                "diagonal mass matrix (diagonal_mass): the reduced step does not apply")
            return
        end if
        if (.not. all(is_finite(self%mass))) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "diagonal_mass returned a " // &
                "mass that is not finite")
            return
        end if
        if (any(self%mass <= 0)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "diagonal_mass returned a " // &
                "mass that is not positive")
            return
        end if
        if (gauss_points < order_n + 1 .or. order_m < 1 .or. order_n < 0) then
            call set_status(status, HOLOSYM_INVALID_ORDER, "the reduced step needs M >= 1, " // &
                "N >= 0 and G >= N + 1")
            return
        end if
        call sys%constraint_sparsity(phi_rows, phi_cols)
        call sys%potential_sparsity(hess_rows, hess_cols)
        self%linear_potential = size(hess_rows) == 0
        call self%layout%build(order_m, n, m, phi_rows, phi_cols, hess_rows, hess_cols, status)
        if (.not. status%ok()) return
        self%order_m = order_m
        self%order_n = order_n
        self%gauss_points = gauss_points
        self%n = n
        self%m = m
        self%nx = self%layout%nx
        call build_tables(self)
        call allocate_workspace(self)
        call dd_tables_init(self%tab, self%n, self%dd)
        call self%fixed%init(self%layout, self%tab%st, self%tab%wl, self%mass)
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine reduced_init

    !> E, S and the tables of the sums, in working precision and rounded to real64.
    subroutine build_tables(self)
        class(reduced_scheme_t), intent(inout) :: self
        integer :: mm, nn, gg, k, info
        real(wp), allocatable :: lobatto_w(:), mom_w(:), gauss_t(:), gauss_w(:)
        real(wp), allocatable :: b(:, :), a(:, :), c(:, :), unused(:, :)
        real(wp), allocatable :: ctwc(:, :), ctwa(:, :), s(:, :)
        integer, allocatable :: pivots(:)
        mm = self%order_m
        nn = self%order_n
        gg = self%gauss_points
        allocate (self%disp_nodes(0:mm), lobatto_w(0:mm), self%mom_nodes(0:nn))
        call gauss_lobatto(self%disp_nodes, lobatto_w)
        if (nn == 0) then
            self%mom_nodes(0) = 0.5_wp
        else
            allocate (mom_w(0:nn))
            call gauss_lobatto(self%mom_nodes, mom_w)
        end if
        allocate (gauss_t(gg), gauss_w(gg))
        call gauss_legendre(gauss_t, gauss_w)
        allocate (b(gg, 0:mm), a(gg, 0:mm), c(gg, 0:nn), unused(gg, 0:nn))
        call lagrange_matrices(self%disp_nodes, gauss_t, b, a)
        call lagrange_matrices(self%mom_nodes, gauss_t, c, unused)
        ! E = (C^T W C)^-1 C^T W A and S = A^T W C E.
        allocate (ctwc(0:nn, 0:nn), ctwa(0:nn, 0:mm), pivots(nn + 1))
        do k = 0, nn
            ctwc(:, k) = matmul(transpose(c), gauss_w * c(:, k))
        end do
        do k = 0, mm
            ctwa(:, k) = matmul(transpose(c), gauss_w * a(:, k))
        end do
        call lu_factor(ctwc, pivots, info)
        call lu_solve(ctwc, pivots, ctwa)   ! now E, (0:N, 0:M)
        allocate (self%e(0:nn, 1:mm))
        self%e = ctwa(:, 1:mm)
        allocate (s(0:mm, 0:mm))
        do k = 0, mm
            s(:, k) = matmul(transpose(a), gauss_w * matmul(c, ctwa(:, k)))
        end do
        ! The kinetic part of the discrete action is (M/2h) z^T S z over z_1..z_M: its
        ! block of S exactly symmetric, as the action needs (row 0 is not used in the
        ! residual: see node_sums).
        s(1:mm, 1:mm) = (s(1:mm, 1:mm) + transpose(s(1:mm, 1:mm))) / 2
        associate (t => self%tab)
            allocate (t%bt(mm, gg), t%st(mm, 0:mm), t%wb(gg, 0:mm), t%w(gg), t%wl(0:mm))
            t%bt = transpose(b(:, 1:mm))
            t%st = transpose(s(:, 1:mm))
            do k = 0, mm
                t%wb(:, k) = gauss_w * b(:, k)
            end do
            t%w = gauss_w
            t%wl = lobatto_w
        end associate
        associate (t => self%low_tab)
            allocate (t%bt(mm, gg), t%st(mm, 0:mm), t%wb(gg, 0:mm), t%w(gg), t%wl(0:mm))
            t%bt = real(self%tab%bt, dp)
            t%st = real(self%tab%st, dp)
            t%wb = real(self%tab%wb, dp)
            t%w = real(self%tab%w, dp)
            t%wl = real(self%tab%wl, dp)
        end associate
        allocate (self%extrap(0:mm, 0:mm))
        do k = 0, mm
            self%extrap(k, :) = lagrange_values(self%disp_nodes, 1 + self%disp_nodes(k))
        end do
        allocate (self%end_weights(mm, 2))
        self%end_weights(:, 1) = matmul(lagrange_values(self%mom_nodes, 0.0_wp), self%e)
        self%end_weights(:, 2) = matmul(lagrange_values(self%mom_nodes, 1.0_wp), self%e)
    end subroutine build_tables

    subroutine allocate_workspace(self)
        class(reduced_scheme_t), intent(inout) :: self
        integer :: n, m, nnz
        n = self%n
        m = self%m
        nnz = size(self%layout%phi_rows)
        call allocate_evaluation_wp(self%ev, n, m, self%order_m, self%gauss_points, nnz)
        call allocate_evaluation_dp(self%low, n, m, self%order_m, self%gauss_points, nnz)
        allocate (self%x_eval(self%nx), self%qa(n), self%pa(n), self%mass_over_h(n), &
                  self%inv_mass(n), self%low_qa(n), self%low_mass_over_h(n), &
                  self%low_inv_mass(n), self%q_work(n), self%g_work(n), self%pv_work(nnz))
        allocate (self%hwb(self%gauss_points, 0:self%order_m), self%hw(self%gauss_points), &
                  self%low_hwb(self%gauss_points, 0:self%order_m), &
                  self%low_hw(self%gauss_points))
        allocate (self%q_nodes(n, self%order_m), self%phi_nodes(m, self%order_m), &
                  self%pv_nodes(nnz, self%order_m), self%p_zeros(n, self%gauss_points), &
                  self%low_p_zeros(n, self%gauss_points))
        self%p_zeros = 0
        self%low_p_zeros = 0
        self%inv_mass = 1 / self%mass
        self%low_inv_mass = real(self%inv_mass, dp)
        allocate (self%jac_values(size(self%layout%jac_col)), &
                  self%dp_values(size(self%layout%dp_col)), self%position(self%nx))
        self%position = 0
        allocate (self%x_low(self%nx), self%f_base(self%nx))
        allocate (self%hu(size(self%layout%near), self%gauss_points), &
                  self%lv(size(self%layout%near), self%order_m), self%kv(nnz))
        self%hu = 0
        self%lv = 0
        self%kv = 0
        allocate (self%q_shift(n), self%steps(n), self%t_base(n), self%t_shift(n), &
                  self%mu_work(m), self%pv_shift(nnz))
        if (.not. self%layout%sparse) allocate (self%hqq(n, n), self%hqp(n, n), &
            self%hpp(n, n), self%phi_hess(n, n, m))
        self%have_eval = .false.
    end subroutine allocate_workspace

    !> Bind the system, the start state and h for the next solve. Phi at q_a is evaluated
    !! here, once per step. With `double_double` the working-precision residuals of the step
    !! sum in double-double arithmetic (where their values are in its range). Code
    !! HOLOSYM_NONFINITE_VALUE.
    subroutine reduced_set_step(self, sys, qa, pa, h, status, double_double)
        class(reduced_scheme_t), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(in) :: qa(:), pa(:) !! start state
        real(wp), intent(in) :: h            !! step size
        type(holosym_status_t), intent(out) :: status !! outcome
        logical, intent(in), optional :: double_double !! sum in double-double arithmetic
        self%sys => sys
        self%qa = qa
        self%pa = pa
        self%h = h
        self%mass_over_h = self%mass / h
        self%hwb = h * self%tab%wb
        self%hw = h * self%tab%w
        self%low_hwb = real(self%hwb, dp)
        self%low_hw = real(self%hw, dp)
        self%low_qa = real(qa, dp)
        self%low_mass_over_h = real(self%mass_over_h, dp)
        self%have_eval = .false.
        self%dd_step = .false.
        if (present(double_double)) then
            if (double_double) call dd_step_tables(h, self%mass_over_h, qa, self%dd, &
                                                   self%dd_step)
        end if
        call node_values(self, qa, 0, self%ev%pv(:, 0), status)
        self%low%pv(:, 0) = real(self%ev%pv(:, 0), dp)
    end subroutine reduced_set_step

    !> The values of Phi at node i (q given), into ev%pv(:, i), checked.
    subroutine node_values(self, q, i, values, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: i
        real(wp), intent(out) :: values(:)
        type(holosym_status_t), intent(out) :: status
        status%code = HOLOSYM_SUCCESS
        if (self%m == 0) return
        call self%sys%constraint_jacobian_values(q, self%layout%phi_rows, self%layout%phi_cols, &
                                                 values)
        call check_values(q, values, "constraint_jacobian_values", "displacement node", i, status)
    end subroutine node_values

    !> grad U at q (user's dh_dq with p = 0), checked.
    subroutine potential_gradient(self, q, gradient, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: gradient(:)
        type(holosym_status_t), intent(out) :: status
        status%code = HOLOSYM_SUCCESS
        call self%sys%dh_dq(q, self%p_zeros(:, 1), gradient)
        self%gradients = self%gradients + 1
        call check_values(q, gradient, "dh_dq", "Gauss point", 0, status)
    end subroutine potential_gradient

    !> The check of the values a system's procedure returned at point q: a non-finite value
    !! at a finite q is the procedure's (code HOLOSYM_NONFINITE_VALUE, naming the procedure
    !! and the point: `where`, then `i` when positive); at a non-finite q the step's own
    !! overflow. Status unchanged when all values are finite.
    subroutine check_values(q, values, procedure_name, where, i, status)
        real(wp), intent(in) :: q(:), values(:)
        character(len=*), intent(in) :: procedure_name, where
        integer, intent(in) :: i
        type(holosym_status_t), intent(inout) :: status
        if (all_finite(values)) return
        if (.not. all(is_finite(q))) then
            call overflow(status)
        else if (i > 0) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, procedure_name // " returned a " // &
                "non-finite value at " // where // " " // int_str(i))
        else
            call set_status(status, HOLOSYM_NONFINITE_VALUE, procedure_name // " returned a " // &
                "non-finite value at a " // where)
        end if
    end subroutine check_values

    !> The step's own arithmetic gave a non-finite point from finite values of the system
    !! (h or the Newton iterate too large): code HOLOSYM_NEWTON_DIVERGED, not a fault of the
    !! system's procedures.
    pure subroutine overflow(status)
        type(holosym_status_t), intent(inout) :: status
        call set_status(status, HOLOSYM_NEWTON_DIVERGED, "the step's equations overflow " // &
            "(non-finite values from finite values of the system)")
    end subroutine overflow

    !> The residual in working precision at x; the evaluation is kept for `increments`.
    subroutine reduced_residual(self, x, f, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: x(:)   !! unknowns (layout order)
        real(wp), intent(out) :: f(:)  !! residual (layout order)
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        integer :: i, l
        logical :: paired
        self%residuals = self%residuals + 1
        self%have_eval = .false.
        associate (ev => self%ev, lay => self%layout)
            call gather_wp(lay%z_col, lay%mu_col, x, ev)
            paired = self%dd_step
            if (paired) paired = dd_fits(ev%z, size(ev%z))
            if (paired) then
                call dd_gauss_positions(self%dd, ev)
            else
                call positions_wp(self%tab, self%qa, ev)
            end if
            call gauss_gradients(self, ev%qg, ev%grad, status)
            if (.not. status%ok()) return
            call node_points(self, ev%z)
            call nodes_values(self, ev%pv(:, 1:self%order_m), status)
            if (.not. status%ok()) return
            call nodes_constraints(self, status)
            if (.not. status%ok()) return
            do i = 1, self%order_m
                do l = 1, self%m  ! element by element: no temporary
                    f(lay%phi_row(l, i)) = self%phi_nodes(l, i)
                end do
            end do
            call forces_wp(lay%phi_rows, lay%phi_cols, ev)
            if (paired) paired = dd_fits(ev%grad, size(ev%grad))
            if (paired) then
                call dd_node_sums(self%dd, self%tab%wl, self%inv_mass, lay%phi_rows, &
                                  lay%phi_cols, ev)
                self%paired_residuals = self%paired_residuals + 1
            else
                call sums_wp(self%tab, self%hwb, self%hw, self%mass_over_h, self%inv_mass, &
                             lay%phi_rows, lay%phi_cols, ev)
            end if
            call rows_wp(lay%d_row, lay%v_row, self%pa, ev, f)
        end associate
        if (refusal_pending()) then
            call check_refusal(status, "")
            return
        end if
        if (.not. all_finite(f)) then
            ! The user's values were finite: the sums overflowed (h or the iterate too large).
            call set_status(status, HOLOSYM_NEWTON_DIVERGED, "the step's equations overflow " &
                // "(non-finite residual from finite values of the system)")
            return
        end if
        self%x_eval = x
        self%have_eval = .true.
    end subroutine reduced_residual

    !> grad U at the Gauss points (user's `dh_dq_points` with p = 0), checked.
    subroutine gauss_gradients(self, qg, grad, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: qg(:, :)     !! the Gauss points (n x G)
        real(wp), intent(out) :: grad(:, :)  !! grad U there (n x G)
        type(holosym_status_t), intent(out) :: status
        integer :: g
        status%code = HOLOSYM_SUCCESS
        call self%sys%dh_dq_points(qg, self%p_zeros, grad)
        self%gradients = self%gradients + self%gauss_points
        do g = 1, self%gauss_points
            call check_values(qg(:, g), grad(:, g), "dh_dq", "Gauss point", g, status)
            if (.not. status%ok()) return
        end do
    end subroutine gauss_gradients

    !> The nodes q_a + z_i, i = 1..M, into q_nodes.
    pure subroutine node_points(self, z)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: z(:, :) !! the displacements (n x M)
        integer :: c, i
        do i = 1, self%order_m
            do c = 1, self%n
                self%q_nodes(c, i) = self%qa(c) + z(c, i)
            end do
        end do
    end subroutine node_points

    !> Phi's values at the nodes q_nodes (one batched call), checked.
    subroutine nodes_values(self, values, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(out) :: values(:, :) !! Phi at the pattern, a node per column
        type(holosym_status_t), intent(out) :: status
        integer :: i
        status%code = HOLOSYM_SUCCESS
        if (self%m == 0) return
        call self%sys%constraint_jacobian_values_points(self%q_nodes, self%layout%phi_rows, &
                                                        self%layout%phi_cols, values)
        do i = 1, self%order_m
            call check_values(self%q_nodes(:, i), values(:, i), "constraint_jacobian_values", &
                              "displacement node", i, status)
            if (.not. status%ok()) return
        end do
    end subroutine nodes_values

    !> phi at the nodes q_nodes (one batched call into phi_nodes), checked.
    subroutine nodes_constraints(self, status)
        class(reduced_scheme_t), intent(inout) :: self
        type(holosym_status_t), intent(out) :: status
        integer :: i
        status%code = HOLOSYM_SUCCESS
        if (self%m == 0) return
        call self%sys%constraint_points(self%q_nodes, self%phi_nodes)
        do i = 1, self%order_m
            call check_values(self%q_nodes(:, i), self%phi_nodes(:, i), "constraint", &
                              "displacement node", i, status)
            if (.not. status%ok()) return
        end do
    end subroutine nodes_constraints

    !> The residual with the sums in real64 at the real64 unknowns x; the gradient of U from
    !! the system's `dh_dq_double`, its other procedures with working-precision arguments;
    !! also p_b - p_a to real64 accuracy in low%dp.
    subroutine reduced_residual_dp(self, x, f, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(dp), intent(in) :: x(:)   !! unknowns (layout order), real64
        real(dp), intent(out) :: f(:)  !! residual (layout order), real64
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        integer :: i, l
        self%lowered_residuals = self%lowered_residuals + 1
        associate (ev => self%low, lay => self%layout)
            call gather_dp(lay%z_col, lay%mu_col, x, ev)
            call positions_dp(self%low_tab, self%low_qa, ev)
            call self%sys%dh_dq_double_points(ev%qg, self%low_p_zeros, ev%grad)
            self%gradients = self%gradients + self%gauss_points
            if (.not. all(ieee_is_finite(ev%grad))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "dh_dq_double returned " &
                    // "a non-finite value at a Gauss point")
                return
            end if
            call node_points(self, real(ev%z, wp))
            call nodes_values(self, self%pv_nodes, status)
            if (.not. status%ok()) return
            ev%pv(:, 1:self%order_m) = real(self%pv_nodes, dp)
            call nodes_constraints(self, status)
            if (.not. status%ok()) return
            do i = 1, self%order_m
                do l = 1, self%m  ! element by element: no temporary
                    f(lay%phi_row(l, i)) = real(self%phi_nodes(l, i), dp)
                end do
            end do
            call forces_dp(lay%phi_rows, lay%phi_cols, ev)
            call sums_dp(self%low_tab, self%low_hwb, self%low_hw, self%low_mass_over_h, &
                         self%low_inv_mass, lay%phi_rows, lay%phi_cols, ev)
            call rows_dp(lay%d_row, lay%v_row, real(self%pa, dp), ev, f)
        end associate
        if (.not. all(ieee_is_finite(f))) call set_status(status, HOLOSYM_NEWTON_DIVERGED, &
            "the step's equations overflow in real64 (non-finite residual from finite " // &
            "values of the system)")
        call check_refusal(status, "")
    end subroutine reduced_residual_dp

    !> The scheme's number of unknowns, `nx`.
    pure integer function equations_unknowns(self)
        class(reduced_equations), intent(in) :: self
        equations_unknowns = self%scheme%nx
    end function equations_unknowns

    !> `set_step` of the scheme.
    subroutine equations_bind(self, sys, qa, pa, h, status)
        class(reduced_equations), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(in) :: qa(:), pa(:) !! start state
        real(wp), intent(in) :: h            !! step size
        type(holosym_status_t), intent(out) :: status !! outcome
        call self%scheme%set_step(sys, qa, pa, h, status)
    end subroutine equations_bind

    !> The constant first guess: no displacement, no multipliers (x = 0).
    subroutine equations_constant_guess(self, x)
        class(reduced_equations), intent(in) :: self
        real(wp), intent(out) :: x(:) !! unknowns (layout order)
        if (.not. associated(self%scheme)) continue
        x = 0
    end subroutine equations_constant_guess

    !> q_b - q_a, p_b - p_a from an evaluation at the solution x (the reduced step saves
    !! that evaluation: it updates the last one to first order, `linear_dp_change`).
    subroutine equations_increments(self, x, dq, dp, status)
        class(reduced_equations), intent(inout) :: self
        real(wp), intent(in) :: x(:)    !! solution
        real(wp), intent(out) :: dq(:)  !! q_b - q_a
        real(wp), intent(out) :: dp(:)  !! p_b - p_a
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        real(wp) :: f(size(x))
        call self%scheme%residual(x, f, status)
        if (.not. status%ok()) return
        call self%scheme%increments(dq, dp, .false.)
    end subroutine equations_increments

    !> Displacement node q_i = q_a + z_i of a solution (q_0 = q_a).
    subroutine equations_solution_node(self, x, i, q)
        class(reduced_equations), intent(in) :: self
        real(wp), intent(in) :: x(:)   !! solution of the bound step
        integer, intent(in) :: i       !! node index, 0..M
        real(wp), intent(out) :: q(:)  !! q_i
        q = self%scheme%qa
        if (i > 0) q = q + x(self%scheme%layout%z_col(:, i))
    end subroutine equations_solution_node

    !> The multipliers lambda_k = mu_k / h at the displacement nodes.
    subroutine equations_node_values(self, x, lambda)
        class(reduced_equations), intent(in) :: self
        real(wp), intent(in) :: x(:)            !! solution of the bound step
        real(wp), intent(out) :: lambda(:, 0:)  !! m x (0:M)
        call self%scheme%multipliers(x, self%scheme%h, lambda)
    end subroutine equations_node_values

    !> `momentum_jump` of the scheme for the bound step.
    function equations_momentum_jump(self, x, dp) result(jump)
        class(reduced_equations), intent(in) :: self
        real(wp), intent(in) :: x(:)   !! solution of the bound step
        real(wp), intent(in) :: dp(:)  !! p_b - p_a
        real(wp) :: jump
        jump = self%scheme%momentum_jump(x, self%scheme%pa, dp, self%scheme%h)
    end function equations_momentum_jump

    !> `dense` of the scheme (its momenta follow from the displacements: pa unused).
    subroutine equations_dense(self, x, qa, pa, h, tau, q, p, lambda)
        class(reduced_equations), intent(in) :: self
        real(wp), intent(in) :: x(:)          !! solution of the step
        real(wp), intent(in) :: qa(:), pa(:)  !! its start state
        real(wp), intent(in) :: h             !! its step size
        real(wp), intent(in) :: tau           !! normalised time t/h
        real(wp), intent(out) :: q(:), p(:), lambda(:)
        if (size(pa) /= size(qa)) continue
        call self%scheme%dense(x, qa, h, tau, q, p, lambda)
    end subroutine equations_dense

    !> The scheme's user-function calls (it keeps no count of Jacobians and Hessians: the
    !! Newton matrices are counted by the iteration).
    function equations_work(self) result(counters)
        class(reduced_equations), intent(in) :: self
        type(scheme_counters_t) :: counters
        counters%residuals = self%scheme%residuals
        counters%lowered_residuals = self%scheme%lowered_residuals
        counters%jacobians = self%scheme%jacobians
        counters%gradients = self%scheme%gradients
    end function equations_work

    !> `residual` of the scheme (for `newton_solve`).
    subroutine equations_residual(self, x, f, status)
        class(reduced_equations), intent(inout) :: self
        real(wp), intent(in) :: x(:)   !! unknowns (layout order)
        real(wp), intent(out) :: f(:)  !! residual (layout order)
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        call self%scheme%residual(x, f, status)
    end subroutine equations_residual

    !> `residual_dp` for `newton_solve`'s pre-solve: the residual with its sums in real64,
    !! at x rounded to real64, in working-precision arrays.
    subroutine equations_residual_lowered(self, x, f, status)
        class(reduced_equations), intent(inout) :: self
        real(wp), intent(in) :: x(:)   !! unknowns (layout order)
        real(wp), intent(out) :: f(:)  !! residual (layout order)
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        real(dp) :: f_low(size(f))
        call self%scheme%residual_dp(real(x, dp), f_low, status)
        f = real(f_low, wp)
    end subroutine equations_residual_lowered

    !> `residual_dp` of the scheme (for `kept_newton_solve`'s real64 phase).
    subroutine equations_residual_dp(self, x, f, status)
        class(reduced_equations), intent(inout) :: self
        real(dp), intent(in) :: x(:)   !! unknowns (layout order)
        real(dp), intent(out) :: f(:)  !! residual (layout order)
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        call self%scheme%residual_dp(x, f, status)
    end subroutine equations_residual_dp

    !> The Newton matrix from the last evaluation (`form_jacobian`), factored in the
    !! layout's pattern (banded when that is cheaper; for `kept_newton_solve`).
    subroutine equations_factor_matrix(self, x, lowered, factors, pivot_tolerance, info, &
                                       status)
        class(reduced_equations), intent(inout) :: self
        real(wp), intent(in) :: x(:)         !! the point of the last evaluation
        logical, intent(in) :: lowered       !! that evaluation was `residual_dp`
        type(real64_factors_t), intent(inout) :: factors !! set up for the layout's band
        real(dp), intent(in) :: pivot_tolerance !! relative pivot threshold (<= 0: default)
        integer, intent(out) :: info         !! 0, or the singular pivot
        type(holosym_status_t), intent(out) :: status !! non-finite second derivatives
        if (size(x) /= self%scheme%nx) continue
        info = 0
        call self%scheme%form_jacobian(lowered, status)
        if (.not. status%ok()) return
        associate (lay => self%scheme%layout)
            call factors%factor(lay%jac_start, lay%jac_col, self%scheme%jac_values, info, &
                                pivot_tolerance)
        end associate
    end subroutine equations_factor_matrix

    !> The iteration matrix without curvature at the last evaluation (x), factored
    !! (`holosym_reduced_multipliers`): Phi at the nodes and the derivative of the hidden
    !! constraint's Phi(q_M) along the end velocity (`end_velocity_curvature`, one
    !! difference of Phi); `info` > 0 when its multiplier systems are singular.
    subroutine equations_factor_approximate(self, x, lowered, info, status)
        class(reduced_equations), intent(inout) :: self
        real(wp), intent(in) :: x(:)         !! the point of the last evaluation
        logical, intent(in) :: lowered       !! that evaluation was `residual_dp`
        integer, intent(out) :: info         !! 0, or > 0: singular
        type(holosym_status_t), intent(out) :: status !! non-finite values of Phi
        if (size(x) /= self%scheme%nx) continue
        info = 0
        associate (scheme => self%scheme, mm => self%scheme%order_m)
            if (.not. lowered) then
                scheme%low%pv = real(scheme%ev%pv, dp)
                scheme%low%z(:, mm) = real(scheme%ev%z(:, mm), dp)
                scheme%low%d(:, mm) = real(scheme%ev%d(:, mm), dp)
            end if
            call set_status(status, HOLOSYM_SUCCESS, "")
            if (scheme%m > 0) call end_velocity_curvature(scheme, status)
            if (.not. status%ok()) return
            if (.not. all(ieee_is_finite(scheme%kv))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "non-finite derivative " // &
                    "of Phi along the end velocity")
                return
            end if
            call scheme%fixed%factor(scheme%h, scheme%low%pv, scheme%kv, info)
        end associate
    end subroutine equations_factor_approximate

    !> The correction of the iteration matrix without curvature for the residual f.
    subroutine equations_solve_approximate(self, f)
        class(reduced_equations), intent(inout) :: self
        real(dp), intent(inout) :: f(:)      !! residual in, correction out
        call self%scheme%fixed%solve(self%scheme%layout, f)
    end subroutine equations_solve_approximate

    !> The Newton matrix at x as a dense matrix (for `newton_solve`): the residual at x,
    !! then `form_jacobian` from that evaluation, its compressed rows expanded.
    subroutine equations_jacobian(self, x, jac, status)
        class(reduced_equations), intent(inout) :: self
        real(wp), intent(in) :: x(:)        !! unknowns (layout order)
        real(wp), intent(out) :: jac(:, :)  !! dF/dx
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        real(wp) :: f(size(x))
        integer :: r, e
        call self%scheme%residual(x, f, status)
        if (status%ok()) call self%scheme%form_jacobian(.false., status)
        if (.not. status%ok()) return
        jac = 0
        associate (lay => self%scheme%layout)
            do r = 1, self%scheme%nx
                do e = lay%jac_start(r), lay%jac_start(r + 1) - 1
                    jac(r, lay%jac_col(e)) = real(self%scheme%jac_values(e), wp)
                end do
            end do
        end associate
    end subroutine equations_jacobian

    !> The Newton matrix and d(p_b - p_a)/dx (real64, in the layout's patterns:
    !! jac_values, dp_values) at the point of the last evaluation, `residual_dp`
    !! (`lowered` true) or `residual`, assembled from the second derivatives of U and phi at
    !! its Gauss points and nodes.
    subroutine reduced_form_jacobian(self, lowered, status)
        class(reduced_scheme_t), intent(inout) :: self
        logical, intent(in) :: lowered !! the last evaluation was `residual_dp`
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        self%jacobians = self%jacobians + 1
        if (.not. lowered) then
            ! The evaluation's points in the real64 workspace that the assembly reads.
            self%low%z = real(self%ev%z, dp)
            self%low%mu = real(self%ev%mu, dp)
            self%low%qg = real(self%ev%qg - spread(self%qa, 2, self%gauss_points), dp) + &
                spread(self%low_qa, 2, self%gauss_points)
            self%low%pv = real(self%ev%pv, dp)
            self%low%d = real(self%ev%d, dp)
        end if
        call second_derivatives(self, status)
        call check_refusal(status, "")
        if (.not. status%ok()) return
        call assemble(self)
    end subroutine reduced_form_jacobian

    !> Second derivatives at the real64 evaluation's points, in real64: the Hessian of U at
    !! each Gauss point and L_i = sum_l mu_il phi_l''(q_i) at nodes 1..M on the coupling
    !! pattern (hu, lv), and K = d(Phi(q) v)/dq at q_M with v = M^-1 D_M on Phi's pattern
    !! (kv). From the system's dense `hessian`/`constraint_hessian` when no sparsity is
    !! declared, else by differences along the colours of the coupling graph.
    subroutine second_derivatives(self, status)
        class(reduced_scheme_t), intent(inout) :: self
        type(holosym_status_t), intent(out) :: status
        integer :: g, i
        status%code = HOLOSYM_SUCCESS
        associate (low => self%low)
            do g = 1, self%gauss_points
                self%q_work = self%qa + real(low%qg(:, g) - self%low_qa, wp)
                if (self%layout%sparse) then
                    if (.not. self%linear_potential) &
                        call potential_differences(self, self%q_work, self%hu(:, g), status)
                else
                    call dense_potential_hessian(self, self%q_work, self%hu(:, g), status)
                end if
                if (.not. status%ok()) return
            end do
            if (self%m == 0) return
            do i = 1, self%order_m
                self%q_work = self%qa + real(low%z(:, i), wp)
                self%mu_work = real(low%mu(:, i), wp)
                if (self%layout%sparse) then
                    call curvature_differences(self, self%q_work, self%mu_work, self%lv(:, i), &
                                               status)
                else
                    call dense_curvature(self, self%q_work, self%mu_work, self%lv(:, i), &
                                         status)
                end if
                if (.not. status%ok()) return
            end do
        end associate
        call end_velocity_curvature(self, status)
        if (.not. status%ok()) return
        if (.not. all(ieee_is_finite(self%hu)) .or. .not. all(ieee_is_finite(self%lv)) .or. &
            .not. all(ieee_is_finite(self%kv))) call set_status(status, &
            HOLOSYM_NONFINITE_VALUE, "non-finite second derivatives of U or phi")
    end subroutine second_derivatives

    !> K = d(Phi(q) v)/dq at q_M with v = M^-1 D_M (kv, on Phi's pattern), from the real64
    !! evaluation's z_M and D_M: K(l, c) = (phi_l'' v)_c, the directional derivative of
    !! Phi(l, c) along v (a difference of Phi, or the system's `constraint_hessian`).
    subroutine end_velocity_curvature(self, status)
        class(reduced_scheme_t), intent(inout) :: self
        type(holosym_status_t), intent(out) :: status
        self%g_work = real(self%low%d(:, self%order_m), wp) * self%inv_mass
        self%q_work = self%qa + real(self%low%z(:, self%order_m), wp)
        if (self%layout%sparse) then
            call direction_differences(self, self%q_work, self%g_work, self%kv, status)
        else
            call dense_direction(self, self%q_work, self%g_work, self%kv, status)
        end if
    end subroutine end_velocity_curvature

    !> Hessian of U at q from the system's `hessian` (d2H/dq2), on the coupling pattern;
    !! HOLOSYM_NONFINITE_VALUE when any of its three blocks is not finite (the two not used
    !! here included: a NaN is never passed over).
    subroutine dense_potential_hessian(self, q, values, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:)
        real(dp), intent(out) :: values(:)
        type(holosym_status_t), intent(inout) :: status
        integer :: c, a
        call self%sys%hessian(q, self%p_zeros(:, 1), self%hqq, self%hqp, self%hpp)
        if (.not. (all(ieee_is_finite(self%hqq)) .and. all(ieee_is_finite(self%hqp)) .and. &
                   all(ieee_is_finite(self%hpp)))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "hessian returned NaN or Inf")
            return
        end if
        do c = 1, self%n
            do a = self%layout%near_start(c), self%layout%near_start(c + 1) - 1
                values(a) = real(self%hqq(c, self%layout%near(a)), dp)
            end do
        end do
    end subroutine dense_potential_hessian

    !> sum_l mu_l phi_l''(q) from the system's `constraint_hessian`, on the coupling pattern.
    subroutine dense_curvature(self, q, mu, values, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:), mu(:)
        real(dp), intent(out) :: values(:)
        type(holosym_status_t), intent(inout) :: status
        integer :: c, a, l
        real(wp) :: total
        call constraint_hessian_checked(self, q, status)
        if (.not. status%ok()) return
        do c = 1, self%n
            do a = self%layout%near_start(c), self%layout%near_start(c + 1) - 1
                total = 0
                do l = 1, self%m
                    total = total + mu(l) * self%phi_hess(c, self%layout%near(a), l)
                end do
                values(a) = real(total, dp)
            end do
        end do
    end subroutine dense_curvature

    !> d(Phi(q) v)/dq from `constraint_hessian`: K(l, c) = sum_k v_k phi_l''(k, c), on
    !! Phi's pattern.
    subroutine dense_direction(self, q, v, values, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:), v(:)
        real(dp), intent(out) :: values(:)
        type(holosym_status_t), intent(inout) :: status
        integer :: e
        call constraint_hessian_checked(self, q, status)
        if (.not. status%ok()) return
        do e = 1, size(values)
            values(e) = real(sum(v * self%phi_hess(:, self%layout%phi_cols(e), &
                                                   self%layout%phi_rows(e))), dp)
        end do
    end subroutine dense_direction

    !> The system's `constraint_hessian` at q into phi_hess; HOLOSYM_NONFINITE_VALUE when
    !! it is not finite.
    subroutine constraint_hessian_checked(self, q, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:)
        type(holosym_status_t), intent(inout) :: status
        call self%sys%constraint_hessian(q, self%phi_hess)
        if (.not. all(ieee_is_finite(self%phi_hess))) call set_status(status, &
            HOLOSYM_NONFINITE_VALUE, "constraint_hessian returned NaN or Inf")
    end subroutine constraint_hessian_checked

    !> Hessian of U at q by forward differences of grad U along the colours.
    subroutine potential_differences(self, q, values, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:)
        real(dp), intent(out) :: values(:)
        type(holosym_status_t), intent(out) :: status
        integer :: k
        call potential_gradient(self, q, self%t_base, status)
        if (.not. status%ok()) return
        do k = 1, self%layout%colors
            call shift_color(self, q, k)
            call potential_gradient(self, self%q_shift, self%t_shift, status)
            if (.not. status%ok()) return
            call color_column(self, k, values)
        end do
    end subroutine potential_differences

    !> sum_l mu_l phi_l''(q) by forward differences of Phi(q)^T mu along the colours.
    subroutine curvature_differences(self, q, mu, values, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:), mu(:)
        real(dp), intent(out) :: values(:)
        type(holosym_status_t), intent(out) :: status
        integer :: k
        call node_values(self, q, 1, self%pv_work, status)
        if (.not. status%ok()) return
        call transpose_product(self, self%pv_work, mu, self%t_base)
        do k = 1, self%layout%colors
            call shift_color(self, q, k)
            call node_values(self, self%q_shift, 1, self%pv_work, status)
            if (.not. status%ok()) return
            call transpose_product(self, self%pv_work, mu, self%t_shift)
            call color_column(self, k, values)
        end do
    end subroutine curvature_differences

    !> d(Phi(q) v)/dq on Phi's pattern: one forward difference of Phi along v.
    subroutine direction_differences(self, q, v, values, status)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:), v(:)
        real(dp), intent(out) :: values(:)
        type(holosym_status_t), intent(out) :: status
        real(wp) :: step
        values = 0
        status%code = HOLOSYM_SUCCESS
        if (maxval(abs(v)) == 0) return
        call node_values(self, q, 1, self%pv_work, status)
        if (.not. status%ok()) return
        self%pv_shift = self%pv_work
        step = difference_step * max(1.0_wp, maxval(abs(q))) / maxval(abs(v))
        self%q_shift = q + step * v
        call node_values(self, self%q_shift, 1, self%pv_work, status)
        if (.not. status%ok()) return
        values = real((self%pv_work - self%pv_shift) / step, dp)
    end subroutine direction_differences

    !> q_shift = q moved along every coordinate of colour k (representable steps kept in
    !! steps(c)).
    subroutine shift_color(self, q, k)
        class(reduced_scheme_t), intent(inout) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: k
        integer :: c
        self%q_shift = q
        do c = 1, self%n
            if (self%layout%color(c) /= k) cycle
            self%q_shift(c) = q(c) + difference_step * max(1.0_wp, abs(q(c)))
            self%steps(c) = self%q_shift(c) - q(c)
        end do
    end subroutine shift_color

    !> Column entries of colour k of a coupled second derivative from the difference
    !! (t_shift - t_base) / step: entry (c, c') belongs to the coupled coordinate c' of c
    !! that has colour k (at most one).
    subroutine color_column(self, k, values)
        class(reduced_scheme_t), intent(inout) :: self
        integer, intent(in) :: k
        real(dp), intent(inout) :: values(:)
        integer :: c, a, col
        do c = 1, self%n
            do a = self%layout%near_start(c), self%layout%near_start(c + 1) - 1
                col = self%layout%near(a)
                if (self%layout%color(col) == k) values(a) = &
                    real((self%t_shift(c) - self%t_base(c)) / self%steps(col), dp)
            end do
        end do
    end subroutine color_column

    !> t = Phi^T mu from values of Phi on its pattern.
    pure subroutine transpose_product(self, values, mu, t)
        class(reduced_scheme_t), intent(in) :: self
        real(wp), intent(in) :: values(:), mu(:)
        real(wp), intent(out) :: t(:)
        integer :: e
        t = 0
        do e = 1, size(values)
            t(self%layout%phi_cols(e)) = t(self%layout%phi_cols(e)) + &
                values(e) * mu(self%layout%phi_rows(e))
        end do
    end subroutine transpose_product

    !> The Newton matrix and d(p_b - p_a)/dx from the second derivatives (see the module
    !! header for the equations), in real64: the rows D_i and d(p_b - p_a) coordinate by
    !! coordinate, then the rows of each constraint (`constraint_derivatives`).
    subroutine assemble(self)
        class(reduced_scheme_t), intent(inout) :: self
        integer :: c, i, l, r
        self%jac_values = 0
        self%dp_values = 0
        associate (lay => self%layout)
            do c = 1, self%n
                do i = 0, self%order_m - 1
                    r = lay%d_row(c, i)
                    call open_row(self%position, lay%jac_start, lay%jac_col, r)
                    call d_derivative(self, c, i, 1.0_dp)
                    call close_row(self%position, lay%jac_start, lay%jac_col, r)
                end do
                call open_row(self%position, lay%dp_start, lay%dp_col, c)
                call dp_derivative(self, c)
                call close_row(self%position, lay%dp_start, lay%dp_col, c)
            end do
            do l = 1, self%m
                call constraint_derivatives(self, l)
            end do
        end associate
    end subroutine assemble

    !> The Newton matrix's rows of constraint l: d phi_l(q_i)/dx (i = 1..M), Phi's row l at
    !! q_i, and d(Phi(q_M) M^-1 D_M)_l/dx, Phi's row times dD_M plus d(Phi(q) v)/dq at q_M.
    subroutine constraint_derivatives(self, l)
        type(reduced_scheme_t), intent(inout) :: self
        integer, intent(in) :: l !! constraint
        integer :: c, i, e, r, mm
        mm = self%order_m
        associate (lay => self%layout, low => self%low)
            do i = 1, mm
                r = lay%phi_row(l, i)
                call open_row(self%position, lay%jac_start, lay%jac_col, r)
                do e = lay%row_entry_start(l), lay%row_entry_start(l + 1) - 1
                    call put(self%position, self%jac_values, &
                             lay%z_col(lay%phi_cols(lay%row_entry(e)), i), &
                             low%pv(lay%row_entry(e), i))
                end do
                call close_row(self%position, lay%jac_start, lay%jac_col, r)
            end do
            r = lay%v_row(l)
            call open_row(self%position, lay%jac_start, lay%jac_col, r)
            do e = lay%row_entry_start(l), lay%row_entry_start(l + 1) - 1
                c = lay%phi_cols(lay%row_entry(e))
                call d_derivative(self, c, mm, low%pv(lay%row_entry(e), mm) * &
                                  self%low_inv_mass(c))
                call put(self%position, self%jac_values, lay%z_col(c, mm), &
                         self%kv(lay%row_entry(e)))
            end do
            call close_row(self%position, lay%jac_start, lay%jac_col, r)
        end associate
    end subroutine constraint_derivatives

    !> Map the columns of row r of a pattern (compressed rows start, col) to their entries:
    !! position(col) = entry, for `put`.
    pure subroutine open_row(position, start, col, r)
        integer, intent(inout) :: position(:) !! column -> entry of the open row
        integer, intent(in) :: start(:)       !! first entry of each row
        integer, intent(in) :: col(:)         !! column of each entry
        integer, intent(in) :: r              !! row to open
        integer :: e
        do e = start(r), start(r + 1) - 1
            position(col(e)) = e
        end do
    end subroutine open_row

    !> Clear the map of `open_row` for row r.
    pure subroutine close_row(position, start, col, r)
        integer, intent(inout) :: position(:) !! column -> entry of the open row
        integer, intent(in) :: start(:)       !! first entry of each row
        integer, intent(in) :: col(:)         !! column of each entry
        integer, intent(in) :: r              !! row to close
        position(col(start(r):start(r + 1) - 1)) = 0
    end subroutine close_row

    !> values(entry of column j in the open row) += value.
    pure subroutine put(position, values, j, value)
        integer, intent(in) :: position(:)    !! column -> entry of the open row
        real(dp), intent(inout) :: values(:)  !! values of the pattern
        integer, intent(in) :: j              !! column
        real(dp), intent(in) :: value         !! addend
        values(position(j)) = values(position(j)) + value
    end subroutine put

    !> factor * dD_i[c]/dx into the open row of the Newton matrix (jac_values):
    !! dD_i[c]/dz_k[c'] = (m_c/h) S(i,k) [c = c'] - h sum_g w_g B_gi B_gk U''_g(c,c')
    !!                    - wl_i L_i(c,c') [k = i];   dD_i[c]/dmu_i[l] = -wl_i Phi_i(l,c).
    subroutine d_derivative(self, c, i, factor)
        type(reduced_scheme_t), intent(inout) :: self
        integer, intent(in) :: c          !! coordinate
        integer, intent(in) :: i          !! node, 0..M
        real(dp), intent(in) :: factor    !! scale of the row
        integer :: a, k, g, cc, e
        real(dp) :: value, h
        h = real(self%h, dp)
        associate (lay => self%layout, tab => self%low_tab)
            do a = lay%near_start(c), lay%near_start(c + 1) - 1
                cc = lay%near(a)
                do k = 1, self%order_m
                    value = 0
                    if (cc == c) value = self%low_mass_over_h(c) * tab%st(k, i)
                    if (.not. self%linear_potential) then
                        do g = 1, self%gauss_points
                            value = value - h * tab%wb(g, i) * tab%bt(k, g) * self%hu(a, g)
                        end do
                    end if
                    if (k == i .and. self%m > 0) value = value - tab%wl(i) * self%lv(a, i)
                    call put(self%position, self%jac_values, lay%z_col(cc, k), factor * value)
                end do
            end do
            do e = lay%col_entry_start(c), lay%col_entry_start(c + 1) - 1
                call put(self%position, self%jac_values, &
                         lay%mu_col(lay%phi_rows(lay%col_entry(e)), i), &
                         -factor * tab%wl(i) * self%low%pv(lay%col_entry(e), i))
            end do
        end associate
    end subroutine d_derivative

    !> d(p_b - p_a)[c]/dx into the open row of the dp pattern (dp_values):
    !! d/dz_k[c'] = -h sum_g w_g B_gk U''_g(c,c') - wl_k L_k(c,c');
    !! d/dmu_i[l] = -wl_i Phi_i(l,c).
    subroutine dp_derivative(self, c)
        type(reduced_scheme_t), intent(inout) :: self
        integer, intent(in) :: c          !! coordinate
        integer :: a, k, g, cc, e, i
        real(dp) :: value, h
        h = real(self%h, dp)
        associate (lay => self%layout, tab => self%low_tab)
            do a = lay%near_start(c), lay%near_start(c + 1) - 1
                cc = lay%near(a)
                do k = 1, self%order_m
                    value = 0
                    if (.not. self%linear_potential) then
                        do g = 1, self%gauss_points
                            value = value - h * tab%w(g) * tab%bt(k, g) * self%hu(a, g)
                        end do
                    end if
                    if (self%m > 0) value = value - tab%wl(k) * self%lv(a, k)
                    call put(self%position, self%dp_values, lay%z_col(cc, k), value)
                end do
            end do
            do e = lay%col_entry_start(c), lay%col_entry_start(c + 1) - 1
                do i = 0, self%order_m
                    call put(self%position, self%dp_values, &
                             lay%mu_col(lay%phi_rows(lay%col_entry(e)), i), &
                             -tab%wl(i) * self%low%pv(lay%col_entry(e), i))
                end do
            end do
        end associate
    end subroutine dp_derivative

    !> Step results from the last evaluation: q_b - q_a = z_M and p_b - p_a, from the
    !! working-precision evaluation (`residual`) or, with `lowered`, the real64 one
    !! (`residual_dp`, real64 accuracy).
    subroutine reduced_increments(self, dq, dpb, lowered)
        class(reduced_scheme_t), intent(in) :: self
        real(wp), intent(out) :: dq(:)   !! q_b - q_a
        real(wp), intent(out) :: dpb(:)  !! p_b - p_a
        logical, intent(in) :: lowered   !! from the real64 evaluation
        if (lowered) then
            dq = real(self%low%z(:, self%order_m), wp)
            dpb = real(self%low%dp, wp)
        else
            dq = self%ev%z(:, self%order_m)
            dpb = self%ev%dp
        end if
    end subroutine reduced_increments

    !> First-order change of p_b - p_a for a change `delta` of the unknowns from the
    !! evaluation point, through the difference matrix d(p_b - p_a)/dx (real64).
    subroutine reduced_linear_dp_change(self, delta, change)
        class(reduced_scheme_t), intent(in) :: self
        real(dp), intent(in) :: delta(:)   !! change of the unknowns
        real(wp), intent(out) :: change(:) !! change of p_b - p_a (n)
        integer :: r, e
        real(dp) :: total
        do r = 1, self%n
            total = 0
            do e = self%layout%dp_start(r), self%layout%dp_start(r + 1) - 1
                total = total + self%dp_values(e) * delta(self%layout%dp_col(e))
            end do
            change(r) = real(total, wp)
        end do
    end subroutine reduced_linear_dp_change

    !> First-order change of p_b - p_a for a change `delta` of the unknowns from the
    !! evaluation point, without curvature: - sum_i wl_i Phi_i^T delta mu_i with Phi at
    !! the nodes of the iteration matrix without curvature (its error, from the left-out
    !! second derivatives, is of the size of the error that matrix leaves in the unknowns).
    subroutine reduced_multiplier_dp_change(self, delta, change)
        class(reduced_scheme_t), intent(in) :: self
        real(dp), intent(in) :: delta(:)   !! change of the unknowns
        real(wp), intent(out) :: change(:) !! change of p_b - p_a (n)
        real(dp) :: total(self%n)
        integer :: i, e
        total = 0
        associate (lay => self%layout)
            do i = 0, self%order_m
                do e = 1, size(lay%phi_rows)
                    total(lay%phi_cols(e)) = total(lay%phi_cols(e)) - self%tab%wl(i) * &
                        self%fixed%pv(e, i) * delta(lay%mu_col(lay%phi_rows(e), i))
                end do
            end do
        end associate
        change = real(total, wp)
    end subroutine reduced_multiplier_dp_change

    !> q~(tau), p~(tau), lambda~(tau) of a solved step with unknowns x from (qa, pa), h.
    !! p~ is the momentum polynomial: p_j = (1/h) M sum_k E(j, k) z_k.
    subroutine reduced_dense(self, x, qa, h, tau, q, p, lambda)
        class(reduced_scheme_t), intent(in) :: self
        real(wp), intent(in) :: x(:), qa(:), h, tau
        real(wp), intent(out) :: q(:), p(:), lambda(:)
        real(wp) :: rho(0:self%order_m), chi(0:self%order_n), weight
        integer :: i, j
        rho = lagrange_values(self%disp_nodes, tau)
        chi = lagrange_values(self%mom_nodes, tau)
        q = qa
        lambda = 0
        p = 0
        do i = 0, self%order_m
            if (i >= 1) then
                q = q + rho(i) * x(self%layout%z_col(:, i))
                weight = 0
                do j = 0, self%order_n
                    weight = weight + chi(j) * self%e(j, i)
                end do
                p = p + weight * x(self%layout%z_col(:, i))
            end if
            if (self%m > 0) lambda = lambda + rho(i) * x(self%layout%mu_col(:, i)) / h
        end do
        p = self%mass * p / h
    end subroutine reduced_dense

    !> max(|p~(0) - p_a|, |p~(1) - p_b|) of a solved step (unknowns x from (qa, pa) with
    !! step h, p_b = pa + dpb): how far the momentum polynomial is from the step's end
    !! momenta. Small (the local error) at the flow's continuation; a spurious root has a
    !! momentum polynomial unrelated to them.
    pure function reduced_momentum_jump(self, x, pa, dpb, h) result(jump)
        class(reduced_scheme_t), intent(in) :: self
        real(wp), intent(in) :: x(:), pa(:), dpb(:), h
        real(wp) :: jump
        real(wp) :: ends(self%n, 2)
        integer :: k
        ends = 0
        do k = 1, self%order_m
            ends(:, 1) = ends(:, 1) + self%end_weights(k, 1) * x(self%layout%z_col(:, k))
            ends(:, 2) = ends(:, 2) + self%end_weights(k, 2) * x(self%layout%z_col(:, k))
        end do
        jump = max(maxval(abs(self%mass * ends(:, 1) / h - pa)), &
                   maxval(abs(self%mass * ends(:, 2) / h - pa - dpb)))
    end function reduced_momentum_jump

    !> Multipliers lambda_k = mu_k / h at the displacement nodes, m x (0:M).
    pure subroutine reduced_multipliers(self, x, h, lambda)
        class(reduced_scheme_t), intent(in) :: self
        real(wp), intent(in) :: x(:), h
        real(wp), intent(out) :: lambda(:, 0:)
        integer :: i
        do i = 0, self%order_m
            lambda(:, i) = x(self%layout%mu_col(:, i)) / h
        end do
    end subroutine reduced_multipliers

    !> First guess from the previous step (unknowns x_prev from qa_prev with the same h):
    !! its polynomials extrapolated to the new step's nodes.
    pure subroutine reduced_extrapolated_guess(self, x_prev, qa_prev, qa, x)
        class(reduced_scheme_t), intent(in) :: self
        real(wp), intent(in) :: x_prev(:), qa_prev(:), qa(:)
        real(wp), intent(out) :: x(:)
        integer :: i, k, c, l
        real(wp) :: total
        associate (lay => self%layout)
            do k = 1, self%order_m
                do c = 1, self%n
                    total = qa_prev(c) - qa(c)
                    do i = 1, self%order_m
                        total = total + self%extrap(k, i) * x_prev(lay%z_col(c, i))
                    end do
                    x(lay%z_col(c, k)) = total
                end do
            end do
            do k = 0, self%order_m
                do l = 1, self%m
                    total = 0
                    do i = 0, self%order_m
                        total = total + self%extrap(k, i) * x_prev(lay%mu_col(l, i))
                    end do
                    x(lay%mu_col(l, k)) = total
                end do
            end do
        end associate
    end subroutine reduced_extrapolated_guess

end module holosym_reduced_scheme
