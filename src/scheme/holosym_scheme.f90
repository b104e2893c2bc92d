!> category: internal module (use holosym)
!! The discrete scheme of one step (q_a, p_a) -> (q_b, p_b) for given (M, N, G):
!! precomputed quadrature and basis matrices, and the residual and Jacobian of the
!! nonlinear system of docs/method.md, section 3.
!!
!! Unknowns x, in increments so that step results are summed without cancellation:
!!   z_i = q_i - q_a (i = 1..M),  w_j = p_j - p_a (j = 0..N),  mu_k = h lambda_k (k = 0..M).
!! Equations (rows, in order): R_p,j (j = 0..N); D_i (i = 1..M-1); p_a + D_0;
!! phi(q_i) (i = 1..M); Phi(q_M) H_p(q_M, D_M), where
!!   D_i = sum_g w_g [A_gi P_g - h B_gi H_q(Q_g, P_g)] - wl_i Phi(q_i)^T mu_i.
!! Where each block of unknowns sits in x and each block of equations in the residual is
!! the layout's (`holosym_scheme_layout`, built by `init`); this module and its kernels
!! take every offset from it.
!!
!! Speed: the quadrature sums that do not involve the user's functions are precomputed
!! (e.g. sum_g w_g C_gj V_g = sum_k SCA(j,k) z_k), all workspace is allocated by `init`
!! (no allocation in `residual` or `jacobian`), and the Jacobian assembly skips Hessian
!! entries that are zero at every Gauss point and sums constant ones once.
module holosym_scheme
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, dp
    use holosym_float_bits, only: all_below_exponent
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NOT_INITIALIZED, real_str
    use holosym_linalg, only: lu_factor_dp, lu_solve_dp
    use holosym_quadrature, only: gauss_legendre, gauss_lobatto
    use holosym_lagrange, only: lagrange_values, lagrange_matrices
    use holosym_problem, only: constrained_hamiltonian, difference_hessian, refusal_pending, &
        check_refusal, &
        difference_constraint_hessian
    use holosym_newton, only: all_finite, all_finite_matrix
    use holosym_step_scheme, only: step_scheme, scheme_counters_t
    use holosym_scheme_layout, only: scheme_layout_t, unknown_count, max_block_order
    use holosym_scheme_linearised, only: linearised_inputs_t, linearised_residual
    ! The kernels of both kinds, under generic names (the type of the first argument
    ! selects the instance): working precision and real64.
    use holosym_scheme_kernels_wp, only: scheme_tables_wp, step_constants_wp, &
        assembly_hessians_wp, entry_zero, entry_constant, entry_varying, assemble_blocks, &
        set_step_constants, allocate_step_constants, allocate_hessians, gauss_state, d_sums, &
        momentum_rows
    use holosym_scheme_kernels_dp, only: scheme_tables_dp, step_constants_dp, &
        assembly_hessians_dp, assemble_blocks, set_step_constants, allocate_step_constants, &
        allocate_hessians, gauss_state, d_sums, momentum_rows
    implicit none
    private

    public :: unknown_count, scheme_counters_t

    !> Largest M accepted. Up to M = 30 the Lagrange basis on the Lobatto nodes reproduces
    !! polynomials to 2e-31 (1e3 epsilon), the row-equilibrated Newton Jacobian keeps pivot
    !! ratios above 3e-6 and the extrapolated first guess converges in about four
    !! iterations; beyond it the basis loses further digits, the extrapolated guess
    !! degrades (relative error 1e-3 at M = 35, 1e4 at M = 45) and the order 2M is far
    !! beyond what real128 round-off lets any step size show (orders above about 30 are
    !! never observed: docs/status-codes.md).
    integer, parameter, public :: max_order_m = max_block_order
    !> Largest N accepted: the momentum polynomial has the same basis and the same limit.
    integer, parameter, public :: max_order_n = max_block_order
    !> Largest G accepted. Gauss-Legendre rules computed in working precision stay exact to
    !! 5e-34 up to 128 points; G = max(M, N) + 1 <= 31 is what the scheme needs, and 64
    !! leaves room for over-integration (extra points beyond M + 3 change no order).
    integer, parameter, public :: max_gauss_points = 64
    !> A lowered (real64) evaluation takes unknowns, gradients and entries of Phi below
    !! 2^492 in magnitude (about 1e148): the products of two such values and their sums
    !! over the nodes and Gauss points (a few thousand terms) stay below huge(1.0_dp),
    !! 2^1024. Beyond it the residual is evaluated in working precision.
    integer, parameter :: lowered_exponent = 492

    !> The tangent map's solve (`refined_solve`) refines a solution with real64 factors at
    !! most this many times: each refinement gains the digits of real64 less those the
    !! condition number takes, so a matrix that real64 factors can handle at all (cond
    !! below about 1e12) reaches real128 round-off in under five.
    integer, parameter :: max_refinements = 10
    !> A refinement that does not shrink the correction by at least this factor has reached
    !! the round-off of the product (or diverges): the refinement stops.
    real(wp), parameter :: refinement_contraction = 0.5_wp
    !> A refined solution whose last correction is above this (relative) is refused: the
    !! tangent would hold fewer than half the working digits (2^(-(p-1)/2) for p binary
    !! digits, sqrt(epsilon) as an integer power that every compiler folds).
    real(wp), parameter :: refined_accuracy = 2.0_wp**(-(digits(1.0_wp) - 1) / 2)

    !> Jacobian assembled from the second derivatives of H and phi (default).
    integer, parameter, public :: JACOBIAN_ASSEMBLED = 1
    !> Jacobian by central differences of the whole residual (2 nx residuals per Jacobian).
    integer, parameter, public :: JACOBIAN_RESIDUAL_DIFFERENCES = 2
    !> Second derivatives from the system's `hessian`/`constraint_hessian` bindings (default).
    integer, parameter, public :: HESSIANS_USER = 1
    !> Second derivatives by central differences of the gradients, ignoring the bindings.
    integer, parameter, public :: HESSIANS_DIFFERENCES = 2

    !> `increments` updates the evaluation cached at a point at distance delta from x to
    !! first order, with second derivatives taken at distance d from x, when
    !! delta (delta + d) <= this (relative to the squared size of the state): the neglected
    !! terms, of order delta^2 and delta d, are then below epsilon.
    real(wp), parameter :: linear_update_limit = epsilon(1.0_wp) / 16

    !> real64 copies of the tables and real64 workspace of `residual_lowered`; its vectors
    !! x, q, p, f also serve as scratch (no allocation per step) for `set_step`, the
    !! first-order increments and the lowered assembly, which never overlap with it.
    type :: lowered_tables_t
        type(scheme_tables_dp) :: tab        ! the tables in real64
        type(step_constants_dp) :: step      ! the step constants in real64
        type(assembly_hessians_dp) :: hess   ! second derivatives in real64
        real(dp), allocatable :: phi_jac(:, :, :) ! m x n x (0:M)
        real(dp), allocatable :: x(:), q(:), p(:)                     ! nx, n, n
        real(dp), allocatable :: hq(:, :), hp(:, :), d(:, :), f(:)    ! n x G, n x G, n x (0:M), nx
    end type lowered_tables_t

    !> The scheme for one (M, N, G) and one problem size (n, m), with its workspace.
    !! Before a Newton solve, `set_step` binds the system, the start state and h.
    type, extends(step_scheme), public :: discrete_scheme
        integer :: order_m = 0       !! M, degree of the displacement polynomial
        integer :: order_n = 0       !! N, degree of the momentum polynomial
        integer :: gauss_points = 0  !! G, Gauss-Legendre points for the Hamiltonian term
        integer :: n = 0             !! coordinates
        integer :: m = 0             !! constraints
        integer :: nx = 0            !! unknowns = equations
        !> Where each block of unknowns and equations lives (set by `init`).
        type(scheme_layout_t), private :: layout
        !> How the Jacobian is formed: JACOBIAN_ASSEMBLED or JACOBIAN_RESIDUAL_DIFFERENCES.
        integer :: jacobian_mode = JACOBIAN_ASSEMBLED
        !> Where second derivatives come from: HESSIANS_USER or HESSIANS_DIFFERENCES.
        integer :: hessian_mode = HESSIANS_USER
        !> `increments` may update the evaluation at the last Newton iterate to first
        !! order instead of evaluating at the solution (see `linear_update_limit`).
        logical :: linear_increments = .false.
        !> Calls made so far.
        type(scheme_counters_t) :: counters
        real(wp), allocatable :: disp_nodes(:)      !! d_0..d_M, Lobatto points
        real(wp), allocatable :: lobatto_weights(:) !! wl_0..wl_M
        real(wp), allocatable :: mom_nodes(:)       !! c_0..c_N
        real(wp), allocatable :: gauss_nodes(:)     !! tau_1..tau_G
        real(wp), allocatable :: gauss_weights(:)   !! w_1..w_G
        real(wp), allocatable :: b(:, :)  !! B(g, i) = rho_i(tau_g), G x (0:M)
        real(wp), allocatable :: a(:, :)  !! A(g, i) = rho_i'(tau_g), G x (0:M)
        real(wp), allocatable :: c(:, :)  !! C(g, j) = chi_j(tau_g), G x (0:N)
        ! Precomputed tables: B, C, their products with the Gauss weights w_g
        ! WB(g,i) = w_g B_gi, WC(g,j) = w_g C_gj, SUM_A(i) = sum_g w_g A_gi, and the
        ! quadrature sums of the Jacobian assembly (sca and sac also enter the residual):
        ! SCA(j,k) = sum_g w_g C_gj A_gk, SCB = .. C_gj B_gk, SCC = .. C_gj C_gl,
        ! SAC(i,l) = .. A_gi C_gl, SBB = .. B_gi B_gk, SBC = .. B_gi C_gl, and their
        ! per-Gauss-point products WCB(g,j,k) = w_g C_gj B_gk, WCC, WBB, WBC.
        type(scheme_tables_wp), private :: tab
        ! Extrapolation to the next step of equal size: rho_i(1 + d_k), chi_j(1 + c_l).
        real(wp), allocatable, private :: extrap_q(:, :) ! (0:M node k, 0:M basis i)
        real(wp), allocatable, private :: extrap_p(:, :) ! (0:N node l, 0:N basis j)
        ! chi_j(0) and chi_j(1): the momentum polynomial at the step's ends.
        real(wp), allocatable, private :: mom_ends(:, :) ! (0:N basis j, 2)
        ! Step context (valid during one solve).
        class(constrained_hamiltonian), pointer, private :: sys => null()
        ! q_a, p_a, h and the sums that depend only on them.
        type(step_constants_wp), private :: step
        ! Workspace of the last evaluation, reused by the Jacobian at the same x.
        real(wp), allocatable, private :: cached_x(:)
        logical, private :: cache_valid = .false.
        ! The cached evaluation came from `residual_lowered` (real64 accuracy only).
        logical, private :: cache_lowered = .false.
        ! hqq, hqp and phi_hess hold second derivatives taken during the current step,
        ! at hessian_x.
        logical, private :: step_hessians = .false.
        real(wp), allocatable, private :: hessian_x(:)
        type(lowered_tables_t), private :: low
        real(wp), allocatable, private :: q_nodes(:, :)      ! n x (0:M)
        real(wp), allocatable, private :: q_gauss(:, :)      ! n x G
        real(wp), allocatable, private :: p_gauss(:, :)      ! n x G
        real(wp), allocatable, private :: hq_gauss(:, :)     ! n x G
        real(wp), allocatable, private :: hp_gauss(:, :)     ! n x G
        real(wp), allocatable, private :: phi_jac(:, :, :)   ! m x n x (0:M)
        real(wp), allocatable, private :: d_values(:, :)     ! n x (0:M)
        real(wp), allocatable, private :: velocity(:)        ! n
        real(wp), allocatable, private :: q_work(:), phi_work(:) ! n, m
        ! Jacobian workspace.
        ! Second derivatives at the Gauss points, the nodes and the step end.
        type(assembly_hessians_wp), private :: hess
        real(wp), allocatable, private :: end_hqq(:, :)      ! n x n (not needed, returned)
        ! Entries of Hqq, Hqp, Hpp zero (0), constant (1) or varying (2) over the Gauss
        ! points: n x n x 3.
        integer, allocatable, private :: patterns(:, :, :)
        real(wp), allocatable, private :: x_work(:), f_plus(:), f_minus(:) ! nx
        ! The step equations linearised at a solution (`linearise`): the values their
        ! derivative needs and the real64 LU factors of the Newton matrix there.
        type(linearised_inputs_t), private :: lin
        real(dp), allocatable, private :: lin_factors(:, :)
        integer, allocatable, private :: lin_pivots(:)
        logical, private :: linearised = .false.
    contains
        !> Set up the scheme for (M, N, G) and sizes (n, m).
        procedure :: init => scheme_init
        !> Check and record (M, N, G) and sizes (n, m) without allocating.
        procedure :: check => scheme_check
        !> Bind the system, start state and step size for the next solve.
        procedure :: set_step => scheme_set_step
        !> `set_step` as the interface of every scheme (`step_scheme`) has it.
        procedure :: bind => scheme_bind
        !> `nx`, as the interface of every scheme has it.
        procedure :: unknowns => scheme_unknowns
        !> The calls made so far (`counters`).
        procedure :: work => scheme_work
        !> Residual of the step equations.
        procedure :: residual => scheme_residual
        !> The residual with the scheme's sums in real64 arithmetic (for a pre-solve).
        procedure :: residual_lowered => scheme_residual_lowered
        !> Jacobian of the step equations.
        procedure :: jacobian => scheme_jacobian
        !> The Jacobian assembled in real64 arithmetic (for the mixed-precision solver).
        procedure :: jacobian_lowered => scheme_jacobian_lowered
        !> The trivial first guess (q_i = q_a, p_j = p_a, lambda = 0).
        procedure :: constant_guess => scheme_constant_guess
        !> First guess from the previous step's polynomials, extrapolated.
        procedure :: extrapolated_guess => scheme_extrapolated_guess
        !> Step results (q_b - q_a, p_b - p_a) from a solution.
        procedure :: increments => scheme_increments
        !> Polynomials q~, p~, lambda~ of a solved step at tau.
        procedure :: dense => scheme_dense
        !> Multipliers lambda_k at the displacement nodes.
        procedure :: node_values => scheme_node_values
        !> Displacement node q_i of a solution.
        procedure :: solution_node => scheme_solution_node
        !> Displacement node q_i of the last evaluation (residual or Jacobian).
        procedure :: node => scheme_node
        !> Distance of the momentum polynomial's ends from the step's end momenta.
        procedure :: momentum_jump => scheme_momentum_jump
        !> The unknowns of the step bound by `set_step` from its node values.
        procedure :: unknowns_from_nodes => scheme_unknowns_from_nodes
        !> Linearise the step equations at a solution (for `tangent`).
        procedure :: linearise => scheme_linearise
        !> The derivative of the step map along a direction of the start state.
        procedure :: tangent => scheme_tangent
        !> The Newton matrix at the linearised solution times a vector of unknowns.
        procedure :: linearised_product => scheme_linearised_product
    end type discrete_scheme

contains

    !> Check (M, N, G) and the sizes (n, m) and record them, without allocating anything.
    !! Codes: HOLOSYM_INVALID_ORDER (M, N or G outside 1..max_order_m, 0..max_order_n,
    !! 1..max_gauss_points, or G < N + 1, which is singular for every system),
    !! HOLOSYM_INVALID_DIMENSION (n < 1, m < 0, m >= n, or more unknowns n_x than the
    !! default integer holds).
    subroutine scheme_check(self, order_m, order_n, gauss_points, n, m, status)
        class(discrete_scheme), intent(inout) :: self
        integer, intent(in) :: order_m      !! M >= 1
        integer, intent(in) :: order_n      !! N >= 0
        integer, intent(in) :: gauss_points !! G >= 1
        integer, intent(in) :: n            !! coordinates, >= 1
        integer, intent(in) :: m            !! constraints, 0 <= m < n
        type(holosym_status_t), intent(out), optional :: status !! outcome

        if (order_m < 1 .or. order_m > max_order_m) then
            call set_status(status, HOLOSYM_INVALID_ORDER, "M must be in 1.." // &
                int_str(max_order_m) // " (the limit of max_order_m); got M = " // &
                int_str(order_m))
            return
        end if
        if (order_n < 0 .or. order_n > max_order_n) then
            call set_status(status, HOLOSYM_INVALID_ORDER, "N must be in 0.." // &
                int_str(max_order_n) // " (the limit of max_order_n); got N = " // &
                int_str(order_n))
            return
        end if
        if (gauss_points < 1 .or. gauss_points > max_gauss_points) then
            call set_status(status, HOLOSYM_INVALID_ORDER, "G must be in 1.." // &
                int_str(max_gauss_points) // " (the limit of max_gauss_points); got G = " // &
                int_str(gauss_points))
            return
        end if
        if (gauss_points < order_n + 1) then
            ! p~ (degree N) enters the equations only through its values at the G Gauss
            ! points: one vanishing there is a null vector of the Jacobian for any system.
            call set_status(status, HOLOSYM_INVALID_ORDER, "G = " // int_str(gauss_points) // &
                " < N + 1 = " // int_str(order_n + 1) // ": the Newton Jacobian is singular " // &
                "for every system (the momentum polynomial is seen only at the G Gauss " // &
                "points); use G >= N + 1, e.g. N = M - 1, G = M + 1")
            return
        end if
        if (n < 1 .or. m < 0 .or. m >= n) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, &
                "need n >= 1 and 0 <= m < n; got n = " &
                // int_str(n) // ", m = " // int_str(m))
            return
        end if
        if (unknown_count(order_m, order_n, n, m) < 0) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "n = " // int_str(n) // &
                ", m = " // int_str(m) // " with M = " // int_str(order_m) // ", N = " // &
                int_str(order_n) // " gives more unknowns than the default integer holds")
            return
        end if
        self%order_m = order_m
        self%order_n = order_n
        self%gauss_points = gauss_points
        self%n = n
        self%m = m
        self%nx = unknown_count(order_m, order_n, n, m)
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine scheme_check

    !> Set up nodes, weights and basis matrices for (M, N, G) and the sizes (n, m).
    !! Codes: those of `check`, and HOLOSYM_INVALID_DIMENSION when the dense workspace
    !! (n_x^2 Newton matrix entries, n^2 m constraint second derivatives) has more entries
    !! than the default integer holds.
    subroutine scheme_init(self, order_m, order_n, gauss_points, n, m, status)
        class(discrete_scheme), intent(inout) :: self
        integer, intent(in) :: order_m      !! M >= 1
        integer, intent(in) :: order_n      !! N >= 0
        integer, intent(in) :: gauss_points !! G >= 1
        integer, intent(in) :: n            !! coordinates, >= 1
        integer, intent(in) :: m            !! constraints, 0 <= m < n
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        real(wp), allocatable :: unused(:, :), mom_weights(:)
        integer :: k

        ! A scheme may be set up again for other orders or sizes: start from scratch.
        call release(self)
        call self%check(order_m, order_n, gauss_points, n, m, local)
        if (local%ok() .and. (int(self%nx, int64)**2 > huge(0) .or. &
                              int(n, int64)**2 * max(m, 1) > huge(0))) then
            call set_status(local, HOLOSYM_INVALID_DIMENSION, "n = " // int_str(n) // &
                ", m = " // int_str(m) // " with M = " // int_str(order_m) // ", N = " // &
                int_str(order_n) // " is too large for the dense Newton matrix of the " // &
                "general scheme (n_x^2 = " // int_str(self%nx) // "^2 and n^2 m must not " // &
                "exceed " // int_str(huge(0)) // ")")
        end if
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        self%counters = scheme_counters_t()
        call self%layout%build(order_m, order_n, gauss_points, n, m)

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

        ! Quadrature sums of the parts that do not involve the user's functions.
        call scheme_sums(self, self%tab)
        call allocate_step_constants(self%step, order_m, order_n, gauss_points, n)
        allocate (self%extrap_q(0:order_m, 0:order_m), self%extrap_p(0:order_n, 0:order_n))
        do k = 0, order_m
            self%extrap_q(k, :) = lagrange_values(self%disp_nodes, 1 + self%disp_nodes(k))
        end do
        do k = 0, order_n
            self%extrap_p(k, :) = lagrange_values(self%mom_nodes, 1 + self%mom_nodes(k))
        end do
        allocate (self%mom_ends(0:order_n, 2))
        self%mom_ends(:, 1) = lagrange_values(self%mom_nodes, 0.0_wp)
        self%mom_ends(:, 2) = lagrange_values(self%mom_nodes, 1.0_wp)

        call lowered_sums(self%tab, self%low%tab)
        call allocate_step_constants(self%low%step, order_m, order_n, gauss_points, n)
        call allocate_hessians(self%low%hess, n, m, order_m, gauss_points, self%nx)
        allocate (self%low%phi_jac(m, n, 0:order_m), self%low%x(self%nx), self%low%q(n), &
                  self%low%p(n), self%low%hq(n, gauss_points), self%low%hp(n, gauss_points), &
                  self%low%d(n, 0:order_m), self%low%f(self%nx))

        allocate (self%cached_x(self%nx), self%hessian_x(self%nx))
        allocate (self%q_nodes(n, 0:order_m), self%d_values(n, 0:order_m))
        allocate (self%q_gauss(n, gauss_points))
        allocate (self%p_gauss(n, gauss_points), self%hq_gauss(n, gauss_points))
        allocate (self%hp_gauss(n, gauss_points), self%phi_jac(m, n, 0:order_m))
        allocate (self%velocity(n), self%q_work(n), self%phi_work(m))
        call allocate_hessians(self%hess, n, m, order_m, gauss_points, self%nx)
        allocate (self%end_hqq(n, n), self%patterns(n, n, 3))
        allocate (self%x_work(self%nx), self%f_plus(self%nx), self%f_minus(self%nx))
        self%cache_valid = .false.
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine scheme_init

    !> Deallocate every array component (before a new `init`).
    subroutine release(self)
        class(discrete_scheme), intent(inout) :: self
        type(lowered_tables_t) :: empty_lowered ! every component unallocated
        if (allocated(self%disp_nodes)) deallocate (self%disp_nodes, self%lobatto_weights, &
            self%mom_nodes, self%gauss_nodes, self%gauss_weights, self%b, self%a, self%c)
        if (allocated(self%extrap_q)) deallocate (self%extrap_q, self%extrap_p, self%mom_ends)
        self%tab = scheme_tables_wp()
        self%step = step_constants_wp()
        self%hess = assembly_hessians_wp()
        if (allocated(self%cached_x)) deallocate (self%cached_x, self%hessian_x, &
            self%q_nodes, &
            self%d_values, self%q_gauss, self%p_gauss, self%hq_gauss, self%hp_gauss, &
            self%phi_jac, self%velocity, self%q_work, self%phi_work)
        if (allocated(self%end_hqq)) deallocate (self%end_hqq, self%patterns, self%x_work, &
            self%f_plus, self%f_minus)
        self%low = empty_lowered
        self%lin = linearised_inputs_t()
        if (allocated(self%lin_factors)) deallocate (self%lin_factors, self%lin_pivots)
        self%linearised = .false.
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
        call set_step_constants(self%tab, self%step, qa, pa, h)
        ! real64 copies in the lowered workspace (free between solves): no temporaries.
        self%low%q = real(qa, dp)
        self%low%p = real(pa, dp)
        call set_step_constants(self%low%tab, self%low%step, self%low%q, self%low%p, &
                                   real(h, dp))
        self%cache_valid = .false.
        self%step_hessians = .false.
        ! q_0 = q_a during the whole solve: its constraint Jacobian is evaluated once.
        self%q_nodes(:, 0) = qa
        if (self%m > 0) call sys%constraint_jacobian(qa, self%phi_jac(:, :, 0))
    end subroutine scheme_set_step

    !> `set_step`, as `step_scheme%bind`: binding never fails here (status success).
    subroutine scheme_bind(self, sys, qa, pa, h, status)
        class(discrete_scheme), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys !! the problem
        real(wp), intent(in) :: qa(:), pa(:) !! start state (n)
        real(wp), intent(in) :: h            !! step size
        type(holosym_status_t), intent(out) :: status !! always success
        call self%set_step(sys, qa, pa, h)
        status%code = HOLOSYM_SUCCESS
    end subroutine scheme_bind

    !> The number of unknowns, `nx`.
    pure integer function scheme_unknowns(self)
        class(discrete_scheme), intent(in) :: self
        scheme_unknowns = self%nx
    end function scheme_unknowns

    !> The user-function calls made since `init` (`counters`).
    function scheme_work(self) result(counters)
        class(discrete_scheme), intent(in) :: self
        type(scheme_counters_t) :: counters
        counters = self%counters
    end function scheme_work

    !> Evaluate the polynomials and the user's first derivatives at x (cached). With
    !! `lowered_ok` an evaluation cached by `residual_lowered` at the same x is accepted.
    subroutine evaluate(self, x, status, lowered_ok)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        type(holosym_status_t), intent(out) :: status
        logical, intent(in), optional :: lowered_ok
        integer :: g

        status%code = HOLOSYM_SUCCESS
        if (self%cache_valid) then
            if (all(x == self%cached_x)) then
                if (.not. self%cache_lowered) return
                if (present(lowered_ok)) then
                    if (lowered_ok) return
                end if
            end if
        end if
        self%cache_valid = .false.
        do g = 1, self%gauss_points
            call gauss_state(self%tab, self%step, self%layout, g, x, self%q_gauss(:, g), &
                             self%p_gauss(:, g))
        end do
        call gauss_gradients(self, status)
        if (.not. status%ok()) return
        call node_jacobians(self, x, status)
        if (.not. status%ok()) return
        call d_sums(self%tab, self%step, self%layout, x, self%hq_gauss, self%phi_jac, &
                    self%d_values)
        self%cached_x = x
        self%cache_valid = .true.
        self%cache_lowered = .false.
    end subroutine evaluate

    !> The user's gradients at the Gauss points (from q_gauss, p_gauss; one batched call
    !! each), checked.
    subroutine gauss_gradients(self, status)
        class(discrete_scheme), intent(inout) :: self
        type(holosym_status_t), intent(out) :: status
        integer :: g
        status%code = HOLOSYM_SUCCESS
        call self%sys%dh_dq_points(self%q_gauss, self%p_gauss, self%hq_gauss)
        call self%sys%dh_dp_points(self%q_gauss, self%p_gauss, self%hp_gauss)
        self%counters%gradients = self%counters%gradients + 2 * self%gauss_points
        do g = 1, self%gauss_points
            if (all_finite(self%hq_gauss(:, g)) .and. all_finite(self%hp_gauss(:, g))) cycle
            ! A non-finite point is the step's overflow, not the system's fault.
            if (.not. (all_finite(self%q_gauss(:, g)) .and. all_finite(self%p_gauss(:, g)))) then
                call overflow(status)
            else
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "dh_dq or dh_dp returned a " &
                    // "non-finite value at Gauss point " // int_str(g))
            end if
            return
        end do
    end subroutine gauss_gradients

    !> Displacement nodes q_i = q_a + z_i and the constraint Jacobians there, checked.
    subroutine node_jacobians(self, x, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        type(holosym_status_t), intent(out) :: status
        integer :: i, base
        status%code = HOLOSYM_SUCCESS
        do i = 1, self%order_m
            base = self%layout%z_at(i)
            self%q_nodes(:, i) = self%step%qa + x(base + 1:base + self%n)
        end do
        do i = 0, self%order_m
            if (i >= 1 .and. self%m > 0) call self%sys%constraint_jacobian(self%q_nodes(:, i), &
                                                                           self%phi_jac(:, :, i))
            if (.not. all_finite_matrix(self%phi_jac(:, :, i))) then
                ! A non-finite node is the step's overflow, not the system's fault.
                if (.not. all_finite(self%q_nodes(:, i))) then
                    call overflow(status)
                else
                    call set_status(status, HOLOSYM_NONFINITE_VALUE, &
                        "constraint_jacobian returned " // &
                        "a non-finite value at displacement node " // int_str(i))
                end if
                return
            end if
        end do
    end subroutine node_jacobians

    !> `evaluate` with the polynomial and quadrature sums in real64 arithmetic; the user's
    !! functions still see working-precision arguments. Accurate to real64 round-off.
    !! `lowered` is false (nothing evaluated) when the iterate, a gradient or Phi is too
    !! large for real64 sums (`lowered_exponent`): the caller evaluates in working
    !! precision.
    subroutine evaluate_lowered(self, x, status, lowered)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        type(holosym_status_t), intent(out) :: status
        logical, intent(out) :: lowered
        integer :: g

        status%code = HOLOSYM_SUCCESS
        self%cache_valid = .false.
        lowered = all_below_exponent(x, size(x), lowered_exponent)
        if (.not. lowered) return
        associate (low => self%low)
            low%x = real(x, dp)
            do g = 1, self%gauss_points
                call gauss_state(low%tab, low%step, self%layout, g, low%x, low%q, low%p)
                self%q_gauss(:, g) = real(low%q, wp)
                self%p_gauss(:, g) = real(low%p, wp)
            end do
            call gauss_gradients(self, status)
            if (.not. status%ok()) return
            lowered = all_below_exponent(self%hq_gauss, size(self%hq_gauss), lowered_exponent) &
                .and. all_below_exponent(self%hp_gauss, size(self%hp_gauss), lowered_exponent)
            if (.not. lowered) return
            low%hq = real(self%hq_gauss, dp)
            low%hp = real(self%hp_gauss, dp)
            call node_jacobians(self, x, status)
            if (.not. status%ok()) return
            lowered = all_below_exponent(self%phi_jac, size(self%phi_jac), lowered_exponent)
            if (.not. lowered) return
            low%phi_jac = real(self%phi_jac, dp)
            call d_sums(low%tab, low%step, self%layout, low%x, low%hq, low%phi_jac, low%d)
            self%d_values = real(low%d, wp)
        end associate
        self%cached_x = x
        self%cache_valid = .true.
        self%cache_lowered = .true.
    end subroutine evaluate_lowered

    !> Residual of the step equations at x (see the module header for the row order).
    subroutine scheme_residual(self, x, f, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)   !! unknowns
        real(wp), intent(out) :: f(:)  !! residual
        type(holosym_status_t), intent(out) :: status !! non-finite user values

        self%counters%residuals = self%counters%residuals + 1
        call evaluate(self, x, status)
        if (.not. status%ok()) return
        call momentum_rows(self%tab, self%step, self%layout, x, self%hp_gauss, &
                           self%d_values, f)
        call constraint_rows(self, f, status)
        call refused_evaluation(self, status)
    end subroutine scheme_residual

    !> `residual` with the scheme's sums in real64 arithmetic, from `evaluate_lowered`:
    !! accurate to real64 round-off, for the first Newton iterations of a mixed-precision
    !! solve. The constraint rows are evaluated as in `residual`.
    subroutine scheme_residual_lowered(self, x, f, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)   !! unknowns
        real(wp), intent(out) :: f(:)  !! residual (real64 accuracy)
        type(holosym_status_t), intent(out) :: status !! non-finite user values

        logical :: lowered
        self%counters%lowered_residuals = self%counters%lowered_residuals + 1
        call evaluate_lowered(self, x, status, lowered)
        if (.not. status%ok()) return
        if (.not. lowered) then
            ! Values beyond real64's safe range (an iterate far from any solution, e.g. at
            ! an absurd h): the working-precision residual, which represents them.
            call self%residual(x, f, status)
            return
        end if
        associate (low => self%low)
            call momentum_rows(low%tab, low%step, self%layout, low%x, low%hp, low%d, low%f)
            associate (rows => self%layout%momentum_rows)
                f(1:rows) = real(low%f(1:rows), wp)
            end associate
        end associate
        call constraint_rows(self, f, status)
        call refused_evaluation(self, status)
    end subroutine scheme_residual_lowered

    !> An evaluation during which the system refused a point (`refuse`) fails with
    !! HOLOSYM_OUTSIDE_DOMAIN and the system's reason, whatever else it found; nothing of
    !! it is cached.
    subroutine refused_evaluation(self, status)
        class(discrete_scheme), intent(inout) :: self
        type(holosym_status_t), intent(inout) :: status
        if (.not. refusal_pending()) return
        self%cache_valid = .false.
        call check_refusal(status, "")
    end subroutine refused_evaluation

    !> The rows phi(q_i), i = 1..M, and Phi(q_M) H_p(q_M, D_M) of the residual, and the
    !! finiteness check of the whole residual.
    subroutine constraint_rows(self, f, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(inout) :: f(:)
        type(holosym_status_t), intent(out) :: status
        integer :: i, l, row, m
        status%code = HOLOSYM_SUCCESS
        m = self%m
        do i = 1, self%order_m
            row = self%layout%phi_row_at(i)
            if (m > 0) call self%sys%constraint(self%q_nodes(:, i), f(row + 1:row + m))
        end do
        call self%sys%dh_dp(self%q_nodes(:, self%order_m), self%d_values(:, self%order_m), &
                            self%velocity)
        self%counters%gradients = self%counters%gradients + 1
        ! The blocks phi(q_1)..phi(q_M) follow each other and end where the last begins.
        row = self%layout%v_row_at
        if (.not. (all_finite(f(self%layout%phi_row_at(1) + 1:row)) .and. &
                   all_finite(self%velocity))) then
            ! dh_dp at a non-finite momentum D_M is the step's overflow, not the system's.
            if (.not. all_finite(self%d_values(:, self%order_m))) then
                call overflow(status)
            else
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint or dh_dp " // &
                    "returned a non-finite value at a displacement node")
            end if
            return
        end if
        do l = 1, m
            f(row + l) = sum(self%phi_jac(l, :, self%order_m) * self%velocity)
        end do
        if (.not. all_finite(f)) call overflow(status)
    end subroutine constraint_rows

    !> The step's own arithmetic gave a non-finite value from finite values of the system
    !! (h or the Newton iterate too large for working precision): code
    !! HOLOSYM_NEWTON_DIVERGED, not a fault of the system's procedures.
    pure subroutine overflow(status)
        type(holosym_status_t), intent(inout) :: status
        call set_status(status, HOLOSYM_NEWTON_DIVERGED, "the step's equations overflow " // &
            "(non-finite values from finite values of the system)")
    end subroutine overflow

    !> Jacobian of the step equations at x: assembled from the second derivatives of H
    !! and phi (the system's own, or central differences of its gradients, as
    !! `hessian_mode` says), or by central differences of the residual (`jacobian_mode`).
    subroutine scheme_jacobian(self, x, jac, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)        !! unknowns
        real(wp), intent(out) :: jac(:, :)  !! nx x nx
        type(holosym_status_t), intent(out) :: status !! non-finite user values

        self%counters%jacobians = self%counters%jacobians + 1
        if (self%jacobian_mode == JACOBIAN_RESIDUAL_DIFFERENCES) then
            call residual_differences(self, x, jac, status)
        else
            call assemble_jacobian(self, x, jac, status)
        end if
        call refused_evaluation(self, status)
    end subroutine scheme_jacobian

    !> `jacobian` in real64: assembled in real64 arithmetic from the same second derivatives
    !! (residual differences are taken in working precision and rounded).
    subroutine scheme_jacobian_lowered(self, x, jac, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)        !! unknowns
        real(dp), intent(out) :: jac(:, :)  !! nx x nx
        type(holosym_status_t), intent(out) :: status !! non-finite user values
        real(wp), allocatable :: full(:, :)

        self%counters%jacobians = self%counters%jacobians + 1
        if (self%jacobian_mode == JACOBIAN_RESIDUAL_DIFFERENCES) then
            allocate (full(self%nx, self%nx))
            call residual_differences(self, x, full, status)
            jac = real(full, dp)
        else
            call assemble_jacobian_lowered(self, x, jac, status)
        end if
        call refused_evaluation(self, status)
    end subroutine scheme_jacobian_lowered

    !> Jacobian column by column from central differences of the residual.
    subroutine residual_differences(self, x, jac, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(wp), intent(out) :: jac(:, :)
        type(holosym_status_t), intent(out) :: status
        real(wp) :: upper, lower, residual_step
        integer :: j
        ! Relative step epsilon**(1/3) (computed here: not every compiler folds real128
        ! powers in a named constant).
        residual_step = epsilon(1.0_wp)**(1.0_wp / 3)
        self%x_work = x
        do j = 1, self%nx
            upper = x(j) + residual_step * max(1.0_wp, abs(x(j)))
            lower = x(j) - residual_step * max(1.0_wp, abs(x(j)))
            self%x_work(j) = upper
            call scheme_residual(self, self%x_work, self%f_plus, status)
            if (.not. status%ok()) return
            self%x_work(j) = lower
            call scheme_residual(self, self%x_work, self%f_minus, status)
            if (.not. status%ok()) return
            self%x_work(j) = x(j)
            ! Differencing the representable neighbours keeps the divisor exact.
            jac(:, j) = (self%f_plus - self%f_minus) / (upper - lower)
        end do
    end subroutine residual_differences

    !> Second derivatives of H at (q, p), from the user or by differences.
    subroutine second_derivatives(self, q, p, hqq, hqp, hpp)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        self%counters%hessians = self%counters%hessians + 1
        if (self%hessian_mode == HESSIANS_DIFFERENCES) then
            call difference_hessian(self%sys, q, p, hqq, hqp, hpp)
            self%counters%gradients = self%counters%gradients + 6 * self%n
        else
            call self%sys%hessian(q, p, hqq, hqp, hpp)
        end if
    end subroutine second_derivatives

    !> Which entries of a set of matrices hess(:, :, g) are zero for all g, equal for all g,
    !! or varying.
    pure subroutine classify(hess, pattern)
        real(wp), intent(in) :: hess(:, :, :)
        integer, intent(out) :: pattern(:, :)
        integer :: a, b
        do b = 1, size(hess, 2)
            do a = 1, size(hess, 1)
                if (all(hess(a, b, :) == hess(a, b, 1))) then
                    if (hess(a, b, 1) == 0) then
                        pattern(a, b) = entry_zero
                    else
                        pattern(a, b) = entry_constant
                    end if
                else
                    pattern(a, b) = entry_varying
                end if
            end do
        end do
    end subroutine classify

    !> The assembled Jacobian.
    subroutine assemble_jacobian(self, x, jac, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(wp), intent(out) :: jac(:, :)
        type(holosym_status_t), intent(out) :: status
        call jacobian_inputs(self, x, status)
        if (.not. status%ok()) return
        call assemble_blocks(self%tab, self%hess, self%patterns, self%layout, self%step%h, x, &
                             self%phi_jac, jac)
    end subroutine assemble_jacobian

    !> The Jacobian assembled in real64 arithmetic (from the same second derivatives).
    subroutine assemble_jacobian_lowered(self, x, jac, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(dp), intent(out) :: jac(:, :)
        type(holosym_status_t), intent(out) :: status
        call jacobian_inputs(self, x, status)
        if (.not. status%ok()) return
        call lowered_assembly(self, x, jac)
    end subroutine assemble_jacobian_lowered

    !> The Jacobian at x in real64 arithmetic from the second derivatives that
    !! `jacobian_inputs` took at x.
    subroutine lowered_assembly(self, x, jac)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(dp), intent(out) :: jac(:, :)
        associate (low => self%low)
            low%hess%hqq = real(self%hess%hqq, dp)
            low%hess%hqp = real(self%hess%hqp, dp)
            low%hess%hpp = real(self%hess%hpp, dp)
            low%phi_jac = real(self%phi_jac, dp)
            if (self%m > 0) then
                low%hess%phi_hess = real(self%hess%phi_hess, dp)
                low%hess%velocity = real(self%hess%velocity, dp)
                low%hess%end_hqp = real(self%hess%end_hqp, dp)
                low%hess%end_hpp = real(self%hess%end_hpp, dp)
            end if
            ! The scaled multipliers in real64, at their places in the lowered residual's
            ! scratch vector (the assembly reads no other unknowns).
            associate (multipliers => self%layout%multipliers, mu0 => self%layout%mu_at(0))
                low%f(mu0 + 1:mu0 + multipliers) = real(x(mu0 + 1:mu0 + multipliers), dp)
            end associate
            call assemble_blocks(low%tab, low%hess, self%patterns, self%layout, low%step%h, &
                                 low%f, low%phi_jac, jac)
        end associate
    end subroutine lowered_assembly

    !> What the assembly needs at x: the evaluation (a lowered one suffices: the Jacobian
    !! only computes corrections), the second derivatives at the Gauss points and nodes,
    !! their patterns, and H_p and its derivatives at the step end (when m > 0).
    subroutine jacobian_inputs(self, x, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        type(holosym_status_t), intent(out) :: status
        integer :: g, i, l, m, mm
        logical :: finite

        call evaluate(self, x, status, lowered_ok=.true.)
        if (.not. status%ok()) return
        m = self%m
        mm = self%order_m
        associate (hess => self%hess)
            do g = 1, self%gauss_points
                call second_derivatives(self, self%q_gauss(:, g), self%p_gauss(:, g), &
                                        hess%hqq(:, :, g), hess%hqp(:, :, g), hess%hpp(:, :, g))
            end do
            do i = 1, mm
                if (m == 0) exit
                self%counters%hessians = self%counters%hessians + 1
                if (self%hessian_mode == HESSIANS_DIFFERENCES) then
                    call difference_constraint_hessian(self%sys, self%q_nodes(:, i), &
                                                       hess%phi_hess(:, :, :, i))
                else
                    call self%sys%constraint_hessian(self%q_nodes(:, i), &
                                                     hess%phi_hess(:, :, :, i))
                end if
            end do
            finite = .true.
            do g = 1, self%gauss_points
                finite = finite .and. all_finite_matrix(hess%hqq(:, :, g)) .and. &
                    all_finite_matrix(hess%hqp(:, :, g)) .and. all_finite_matrix(hess%hpp(:, :, g))
            end do
            do i = 1, mm
                do l = 1, m
                    finite = finite .and. all_finite_matrix(hess%phi_hess(:, :, l, i))
                end do
            end do
            if (.not. finite) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "second derivatives of H " // &
                    "or phi are not finite")
                return
            end if
            self%step_hessians = .true.
            self%hessian_x = x
            call classify(hess%hqq, self%patterns(:, :, 1))
            call classify(hess%hqp, self%patterns(:, :, 2))
            call classify(hess%hpp, self%patterns(:, :, 3))
            if (m == 0) return
            ! Phi(q_M) H_p(q_M, p_b), p_b = D_M, is differentiated through H_p at the end.
            call self%sys%dh_dp(self%q_nodes(:, mm), self%d_values(:, mm), hess%velocity)
            self%counters%gradients = self%counters%gradients + 1
            call second_derivatives(self, self%q_nodes(:, mm), self%d_values(:, mm), &
                                    self%end_hqq, hess%end_hqp, hess%end_hpp)
            if (.not. (all_finite(hess%velocity) .and. all_finite_matrix(hess%end_hqp) .and. &
                       all_finite_matrix(hess%end_hpp))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, &
                    "dh_dp or its derivatives are not finite at the step end")
            end if
        end associate
    end subroutine jacobian_inputs

    !> The tables of the residual and the Jacobian assembly (sca and sac enter both).
    !! Keep the computed sums even where they equal rho_i(1) - rho_i(0) in exact
    !! arithmetic: with the exact +-1, 0 the equations are no longer exactly the gradient
    !! of one discrete action, and round-off then drifts linearly instead of randomly.
    subroutine scheme_sums(self, tab)
        class(discrete_scheme), intent(in) :: self
        type(scheme_tables_wp), intent(out) :: tab
        integer :: g, i, j, k, mm, nn, gg
        mm = self%order_m
        nn = self%order_n
        gg = self%gauss_points
        allocate (tab%b(gg, 0:mm), tab%c(gg, 0:nn), tab%wb(gg, 0:mm), tab%wc(gg, 0:nn), &
                  tab%sum_a(0:mm), tab%sca(0:nn, mm), tab%scb(0:nn, mm), tab%scc(0:nn, 0:nn), &
                  tab%sac(0:mm, 0:nn), tab%sbb(0:mm, mm), tab%sbc(0:mm, 0:nn), &
                  tab%wcb(gg, 0:nn, mm), tab%wcc(gg, 0:nn, 0:nn), tab%wbb(gg, 0:mm, mm), &
                  tab%wbc(gg, 0:mm, 0:nn), tab%lobatto_weights(0:mm))
        tab%b = self%b
        tab%c = self%c
        tab%w = self%gauss_weights
        do g = 1, gg
            tab%wb(g, :) = self%gauss_weights(g) * self%b(g, :)
            tab%wc(g, :) = self%gauss_weights(g) * self%c(g, :)
        end do
        do i = 0, mm
            tab%sum_a(i) = sum(self%gauss_weights * self%a(:, i))
        end do
        tab%lobatto_weights = self%lobatto_weights
        associate (wb => tab%wb, wc => tab%wc)
            do k = 1, mm
                do j = 0, nn
                    tab%sca(j, k) = sum(wc(:, j) * self%a(:, k))
                    tab%scb(j, k) = sum(wc(:, j) * self%b(:, k))
                    tab%wcb(:, j, k) = wc(:, j) * self%b(:, k)
                end do
                do i = 0, mm
                    tab%sbb(i, k) = sum(wb(:, i) * self%b(:, k))
                    tab%wbb(:, i, k) = wb(:, i) * self%b(:, k)
                end do
            end do
            do j = 0, nn
                do k = 0, nn
                    tab%scc(k, j) = sum(wc(:, k) * self%c(:, j))
                    tab%wcc(:, k, j) = wc(:, k) * self%c(:, j)
                end do
                do i = 0, mm
                    tab%sac(i, j) = sum(self%gauss_weights * self%a(:, i) * self%c(:, j))
                    tab%sbc(i, j) = sum(wb(:, i) * self%c(:, j))
                    tab%wbc(:, i, j) = wb(:, i) * self%c(:, j)
                end do
            end do
        end associate
    end subroutine scheme_sums

    !> real64 copies of the tables (with their index bounds).
    subroutine lowered_sums(tab, low)
        type(scheme_tables_wp), intent(in) :: tab
        type(scheme_tables_dp), intent(out) :: low
        call lower_2d(tab%b, low%b)
        call lower_2d(tab%c, low%c)
        call lower_2d(tab%wb, low%wb)
        call lower_2d(tab%wc, low%wc)
        call lower_1d(tab%w, low%w)
        call lower_2d(tab%sca, low%sca)
        call lower_2d(tab%scb, low%scb)
        call lower_2d(tab%scc, low%scc)
        call lower_2d(tab%sac, low%sac)
        call lower_2d(tab%sbb, low%sbb)
        call lower_2d(tab%sbc, low%sbc)
        call lower_3d(tab%wcb, low%wcb)
        call lower_3d(tab%wcc, low%wcc)
        call lower_3d(tab%wbb, low%wbb)
        call lower_3d(tab%wbc, low%wbc)
        call lower_1d(tab%lobatto_weights, low%lobatto_weights)
        call lower_1d(tab%sum_a, low%sum_a)
    contains
        ! Allocate first: assignment of an expression would make every lower bound 1.
        subroutine lower_1d(source, copy)
            real(wp), allocatable, intent(in) :: source(:)
            real(dp), allocatable, intent(out) :: copy(:)
            allocate (copy(lbound(source, 1):ubound(source, 1)))
            copy = real(source, dp)
        end subroutine lower_1d
        subroutine lower_2d(source, copy)
            real(wp), allocatable, intent(in) :: source(:, :)
            real(dp), allocatable, intent(out) :: copy(:, :)
            allocate (copy(lbound(source, 1):ubound(source, 1), &
                           lbound(source, 2):ubound(source, 2)))
            copy = real(source, dp)
        end subroutine lower_2d
        subroutine lower_3d(source, copy)
            real(wp), allocatable, intent(in) :: source(:, :, :)
            real(dp), allocatable, intent(out) :: copy(:, :, :)
            allocate (copy(lbound(source, 1):ubound(source, 1), &
                           lbound(source, 2):ubound(source, 2), &
                           lbound(source, 3):ubound(source, 3)))
            copy = real(source, dp)
        end subroutine lower_3d
    end subroutine lowered_sums

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
        integer :: i, j, k, n, m, base
        n = self%n
        m = self%m
        if (h == h_prev) then
            ! Equal steps: precomputed rho_i(1 + d_k), chi_j(1 + c_l), no allocation. The
            ! sums stay in working precision although a guess needs less: a guess rounded
            ! to real64 leaves a rounding component in Newton's last iterate, which makes
            ! round-off grow faster over long runs (see docs/design.md).
            associate (lay => self%layout)
                do k = 0, self%order_m
                    if (k >= 1) then
                        base = lay%z_at(k)
                        x(base + 1:base + n) = qa_prev - qa
                        do i = 1, self%order_m
                            x(base + 1:base + n) = x(base + 1:base + n) + self%extrap_q(k, i) &
                                * x_prev(lay%z_at(i) + 1:lay%z_at(i) + n)
                        end do
                    end if
                    base = lay%mu_at(k)
                    x(base + 1:base + m) = 0
                    do i = 0, self%order_m
                        x(base + 1:base + m) = x(base + 1:base + m) + self%extrap_q(k, i) * &
                            x_prev(lay%mu_at(i) + 1:lay%mu_at(i) + m)
                    end do
                end do
                do k = 0, self%order_n
                    base = lay%w_at(k)
                    x(base + 1:base + n) = pa_prev - pa
                    do j = 0, self%order_n
                        x(base + 1:base + n) = x(base + 1:base + n) + self%extrap_p(k, j) * &
                            x_prev(lay%w_at(j) + 1:lay%w_at(j) + n)
                    end do
                end do
            end associate
            return
        end if
        call general_ratio()

    contains

        !> Unequal steps: evaluate the previous polynomials at 1 + (h/h_prev) d_k.
        subroutine general_ratio()
            real(wp) :: q(self%n), p(self%n), lambda(self%m), ratio
            integer :: i, j, base
            ratio = h / h_prev
            do i = 0, self%order_m
                call self%dense(x_prev, qa_prev, pa_prev, h_prev, 1 + ratio * self%disp_nodes(i), &
                                q, p, lambda)
                if (i >= 1) then
                    base = self%layout%z_at(i)
                    x(base + 1:base + n) = q - qa
                end if
                base = self%layout%mu_at(i)
                x(base + 1:base + m) = h * lambda
            end do
            do j = 0, self%order_n
                call self%dense(x_prev, qa_prev, pa_prev, h_prev, 1 + ratio * self%mom_nodes(j), &
                                q, p, lambda)
                base = self%layout%w_at(j)
                x(base + 1:base + n) = p - pa
            end do
        end subroutine general_ratio

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
        integer :: g, i, l, base
        real(wp) :: coefficient
        logical :: linear
        ! The last Newton correction is tiny: update the evaluation at the previous iterate
        ! to first order (second derivatives of this step) rather than evaluate again.
        linear = near_cached_exact(self, x)
        if (.not. linear) then
            call evaluate(self, x, status)
            if (.not. status%ok()) return
        end if
        status%code = HOLOSYM_SUCCESS
        base = self%layout%z_at(self%order_m)
        dq = x(base + 1:base + self%n)
        dp = 0
        do g = 1, self%gauss_points
            coefficient = self%step%h * self%gauss_weights(g)
            dp = dp - coefficient * self%hq_gauss(:, g)
        end do
        do i = 0, self%order_m
            do l = 1, self%m
                coefficient = self%lobatto_weights(i) * x(self%layout%mu_at(i) + l)
                dp = dp - coefficient * self%phi_jac(l, :, i)
            end do
        end do
        if (linear) then
            call first_order_change(self, x)
            dp = dp - real(self%low%f(1:self%n), wp)
        end if
        end subroutine scheme_increments

    !> True when the cache holds an exact evaluation within `linear_update_limit` of x and
    !! the second derivatives of this step are at hand (assembled Jacobian).
    logical function near_cached_exact(self, x)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: x(:)
        real(wp) :: size_of_state, delta, distance
        near_cached_exact = .false.
        if (.not. self%linear_increments) return
        if (.not. (self%cache_valid .and. self%step_hessians)) return
        if (self%cache_lowered .or. self%jacobian_mode /= JACOBIAN_ASSEMBLED) return
        size_of_state = max(1.0_wp, maxval(abs(self%step%qa)), maxval(abs(self%step%pa)), &
                            maxval(abs(x)))
        delta = maxval(abs(x - self%cached_x))
        ! The second derivatives may come from a lowered evaluation (real64 round-off).
        distance = maxval(abs(x - self%hessian_x)) + real(epsilon(1.0_dp), wp) * size_of_state
        near_cached_exact = delta * (delta + distance) <= linear_update_limit * size_of_state**2
    end function near_cached_exact

    !> First-order change of h sum_g w_g H_q(Q_g, P_g) + sum_i wl_i Phi(q_i)^T mu_i from the
    !! cached x to x through Q, P and q_i (the mu_i enter exactly in `increments`), in
    !! real64: the change is ~1e-30, so real64 and second derivatives taken anywhere in
    !! this step are accurate enough. Result in low%f(1:n).
    subroutine first_order_change(self, x)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        real(dp) :: weight
        integer :: g, i, j, l, a, b, base, n
        n = self%n
        ! Workspace of the lowered residual (free after the solve): no allocation.
        associate (delta => self%low%x, dq_g => self%low%q, dp_g => self%low%p, &
                   change => self%low%f(1:n))
            delta = real(x - self%cached_x, dp)
            change = 0
            do g = 1, self%gauss_points
                dq_g = 0
                do i = 1, self%order_m
                    base = self%layout%z_at(i)
                    dq_g = dq_g + self%low%tab%b(g, i) * delta(base + 1:base + n)
                end do
                dp_g = 0
                do j = 0, self%order_n
                    base = self%layout%w_at(j)
                    dp_g = dp_g + self%low%tab%c(g, j) * delta(base + 1:base + n)
                end do
                weight = real(self%step%h * self%gauss_weights(g), dp)
                do b = 1, n
                    do a = 1, n
                        change(a) = change(a) + weight * (real(self%hess%hqq(a, b, g), dp) &
                            * dq_g(b) + real(self%hess%hqp(a, b, g), dp) * dp_g(b))
                    end do
                end do
            end do
            ! d/dq_i (Phi(q_i)^T mu_i) = sum_l mu_il phi_l''(q_i); q_0 = q_a does not move.
            do i = 1, self%order_m
                base = self%layout%z_at(i)
                do l = 1, self%m
                    weight = self%low%tab%lobatto_weights(i) * &
                    real(x(self%layout%mu_at(i) + l), dp)
                    do b = 1, n
                        do a = 1, n
                            change(a) = change(a) + weight * &
                                real(self%hess%phi_hess(a, b, l, i), dp) * delta(base + b)
                        end do
                    end do
                end do
            end do
        end associate
    end subroutine first_order_change

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
        integer :: i, j, base
        rho = lagrange_values(self%disp_nodes, tau)
        chi = lagrange_values(self%mom_nodes, tau)
        q = qa
        lambda = 0
        do i = 0, self%order_m
            if (i >= 1) then
                base = self%layout%z_at(i)
                q = q + rho(i) * x(base + 1:base + self%n)
            end if
            base = self%layout%mu_at(i)
            lambda = lambda + rho(i) * x(base + 1:base + self%m) / h
        end do
        p = pa
        do j = 0, self%order_n
            base = self%layout%w_at(j)
            p = p + chi(j) * x(base + 1:base + self%n)
        end do
    end subroutine scheme_dense

    !> max(|p~(0) - p_a|, |p~(1) - p_b|) of a solved step (solution x, p_b = p_a + dp):
    !! how far the momentum polynomial is from the step's end momenta. Small (the local
    !! error) at the flow's continuation; a spurious root has a momentum polynomial
    !! unrelated to them. p~(tau) - p_a = sum_j chi_j(tau) w_j.
    pure function scheme_momentum_jump(self, x, dp) result(jump)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: x(:)   !! solution of the step
        real(wp), intent(in) :: dp(:)  !! p_b - p_a
        real(wp) :: jump
        real(wp) :: ends(self%n, 2)
        integer :: j, base
        ends = 0
        do j = 0, self%order_n
            base = self%layout%w_at(j)
            ends(:, 1) = ends(:, 1) + self%mom_ends(j, 1) * x(base + 1:base + self%n)
            ends(:, 2) = ends(:, 2) + self%mom_ends(j, 2) * x(base + 1:base + self%n)
        end do
        jump = max(maxval(abs(ends(:, 1))), maxval(abs(ends(:, 2) - dp)))
    end function scheme_momentum_jump

    !> Displacement node q_i (i = 0..M) of the point of the last evaluation: after a
    !! failed Newton solve, the nodes of the iterate where it stopped.
    pure subroutine scheme_node(self, i, q)
        class(discrete_scheme), intent(in) :: self
        integer, intent(in) :: i       !! node index, 0..M
        real(wp), intent(out) :: q(:)  !! q_i (n)
        q = self%q_nodes(:, i)
    end subroutine scheme_node

    !> Multipliers at the displacement nodes, lambda_k = mu_k / h, k = 0..M.
    subroutine scheme_node_values(self, x, lambda)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: x(:)            !! solution of the step bound by set_step
        real(wp), intent(out) :: lambda(:, 0:)  !! m x (0:M) multipliers lambda_k
        integer :: i, base
        do i = 0, self%order_m
            base = self%layout%mu_at(i)
            lambda(:, i) = x(base + 1:base + self%m) / self%step%h
        end do
    end subroutine scheme_node_values

    !> The displacement node q_i = q_a + z_i (q_0 = q_a) of the solution x of the step
    !! bound by `set_step`.
    subroutine scheme_solution_node(self, x, i, q)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: x(:)   !! solution of the step bound by set_step
        integer, intent(in) :: i       !! node index, 0..M
        real(wp), intent(out) :: q(:)  !! q_i (n)
        integer :: base
        q = self%step%qa
        if (i >= 1) then
            base = self%layout%z_at(i)
            q = q + x(base + 1:base + self%n)
        end if
    end subroutine scheme_solution_node

    !> The unknowns x of the step bound by `set_step` whose polynomials take the values
    !! q_i (i = 1..M, displacement nodes), p_j (j = 0..N, momentum nodes) and lambda_i
    !! (i = 0..M): the inverse of `dense` at the nodes (`disp_nodes`, `mom_nodes`), for a
    !! step another scheme solved.
    pure subroutine scheme_unknowns_from_nodes(self, q, p, lambda, x)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: q(:, 0:)      !! n x (0:M) q~ at the displacement nodes
        real(wp), intent(in) :: p(:, 0:)      !! n x (0:N) p~ at the momentum nodes
        real(wp), intent(in) :: lambda(:, 0:) !! m x (0:M) lambda~ at the displacement nodes
        real(wp), intent(out) :: x(:)         !! unknowns (nx)
        integer :: i, base
        associate (lay => self%layout, n => self%n, m => self%m)
            do i = 1, self%order_m
                base = lay%z_at(i)
                x(base + 1:base + n) = q(:, i) - self%step%qa
            end do
            do i = 0, self%order_n
                base = lay%w_at(i)
                x(base + 1:base + n) = p(:, i) - self%step%pa
            end do
            do i = 0, self%order_m
                base = lay%mu_at(i)
                x(base + 1:base + m) = self%step%h * lambda(:, i)
            end do
        end associate
    end subroutine scheme_unknowns_from_nodes

    !> Linearise the step equations at their solution x for the step bound by `set_step`:
    !! an evaluation in working precision, the second derivatives of H at the Gauss points
    !! and the step end and of phi at every node (q_0 = q_a too), and the real64 LU factors
    !! of the Newton matrix, for `tangent`. HOLOSYM_SINGULAR_MATRIX when the Newton matrix
    !! is singular at x; HOLOSYM_NONFINITE_VALUE as the Jacobian reports it.
    subroutine scheme_linearise(self, x, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: x(:) !! solution of the step bound by set_step
        type(holosym_status_t), intent(out) :: status !! outcome
        integer :: info, i
        self%linearised = .false.
        ! Exact first: the second derivatives must be taken at the exact Gauss points.
        call evaluate(self, x, status)
        if (status%ok()) call jacobian_inputs(self, x, status)
        if (.not. status%ok()) return
        associate (s => self%lin)
            s = linearised_inputs_t(h=self%step%h, b=self%b, a=self%a, c=self%c, &
                                    w=self%gauss_weights, lobatto_weights=self%lobatto_weights, &
                                    hqq=self%hess%hqq, hqp=self%hess%hqp, hpp=self%hess%hpp, &
                                    phi_jac=self%phi_jac)
            allocate (s%phi_hess(self%n, self%n, self%m, 0:self%order_m), &
                      s%mu(self%m, 0:self%order_m))
            do i = 0, self%order_m
                s%mu(:, i) = x(self%layout%mu_at(i) + 1:self%layout%mu_at(i) + self%m)
            end do
            if (self%m > 0) then
                s%phi_hess(:, :, :, 1:) = self%hess%phi_hess
                call start_constraint_hessian(self, s%phi_hess(:, :, :, 0), status)
                if (.not. status%ok()) return
                s%velocity = self%hess%velocity
                s%end_hqp = self%hess%end_hqp
                s%end_hpp = self%hess%end_hpp
            end if
        end associate
        if (.not. allocated(self%lin_factors)) &
            allocate (self%lin_factors(self%nx, self%nx), self%lin_pivots(self%nx))
        call lowered_assembly(self, x, self%lin_factors)
        call lu_factor_dp(self%lin_factors, self%lin_pivots, info)
        if (info /= 0) then
            call set_status(status, HOLOSYM_SINGULAR_MATRIX, "the Newton matrix of the " // &
                "step is singular at its solution: no tangent map")
            return
        end if
        self%linearised = .true.
    end subroutine scheme_linearise

    !> Second derivatives of phi at q_0 = q_a (the Newton matrix does not need them: q_a
    !! is no unknown), from the same source as the other nodes'.
    subroutine start_constraint_hessian(self, hessian, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(out) :: hessian(:, :, :)
        type(holosym_status_t), intent(inout) :: status
        integer :: l
        self%counters%hessians = self%counters%hessians + 1
        if (self%hessian_mode == HESSIANS_DIFFERENCES) then
            call difference_constraint_hessian(self%sys, self%step%qa, hessian)
        else
            call self%sys%constraint_hessian(self%step%qa, hessian)
        end if
        do l = 1, self%m
            if (.not. all_finite_matrix(hessian(:, :, l))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "second derivatives of " // &
                    "phi are not finite at the step start")
                return
            end if
        end do
    end subroutine start_constraint_hessian

    !> The derivative (dq_b, dp_b) of the step map (q_a, p_a) -> (q_b, p_b) along
    !! (dq_a, dp_a), at the solution `linearise` took: by the implicit-function theorem on
    !! the step equations F(x; q_a, p_a) = 0, dx = -F_x^-1 (F_qa dq_a + F_pa dp_a), one
    !! solve with the Newton matrix's factors, refined in working precision.
    !! HOLOSYM_SINGULAR_MATRIX when the refinement does not converge (a Newton matrix too
    !! ill-conditioned for real64 factors); HOLOSYM_NOT_INITIALIZED before `linearise`.
    subroutine scheme_tangent(self, dqa, dpa, dqb, dpb, status)
        class(discrete_scheme), intent(inout) :: self
        real(wp), intent(in) :: dqa(:)  !! direction of q_a (n)
        real(wp), intent(in) :: dpa(:)  !! direction of p_a (n)
        real(wp), intent(out) :: dqb(:) !! derivative of q_b (n)
        real(wp), intent(out) :: dpb(:) !! derivative of p_b (n)
        type(holosym_status_t), intent(out) :: status !! outcome
        real(wp) :: dq(self%n, 0:self%order_m), dp(self%n, 0:self%order_n)
        real(wp) :: dmu(self%m, 0:self%order_m), rhs(self%nx), y(self%nx)
        integer :: row
        if (.not. self%linearised) then
            call set_status(status, HOLOSYM_NOT_INITIALIZED, "tangent before linearise")
            return
        end if
        ! With the unknowns offsets from (q_a, p_a), F_qa dq_a is the derivative along
        ! dq_a at every node q_0..q_M, F_pa dp_a along dp_a at every p_j plus the p_a of
        ! the row p_a + D_0.
        dq = spread(dqa, 2, self%order_m + 1)
        dp = spread(dpa, 2, self%order_n + 1)
        dmu = 0
        call linearised_residual(self%lin, self%layout, dq, dp, dmu, rhs, dpb)
        row = self%layout%d_row_at(0)
        rhs(row + 1:row + self%n) = rhs(row + 1:row + self%n) + dpa
        call refined_solve(self, rhs, y, status)
        if (.not. status%ok()) return
        ! The nodes move by dq_a + dz_i, dz = -y (q_0 by dq_a), the momenta by dp_a + dw_j.
        call unknown_directions(self, -y, dq, dp, dmu, dqa, dpa)
        call linearised_residual(self%lin, self%layout, dq, dp, dmu, rhs, dpb)
        dqb = dq(:, self%order_m)
    end subroutine scheme_tangent

    !> Newton matrix at the linearised solution times y (a vector of unknowns), from the
    !! derivative of the equations rather than the assembled matrix.
    subroutine scheme_linearised_product(self, y, f)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: y(:)  !! nx
        real(wp), intent(out) :: f(:) !! nx
        real(wp) :: dq(self%n, 0:self%order_m), dp(self%n, 0:self%order_n)
        real(wp) :: dmu(self%m, 0:self%order_m), d_end(self%n)
        call unknown_directions(self, y, dq, dp, dmu)
        call linearised_residual(self%lin, self%layout, dq, dp, dmu, f, d_end)
    end subroutine scheme_linearised_product

    !> The directions of the nodes, momenta and multipliers of a direction y of the
    !! unknowns, plus a common direction (dq_a, dp_a) of the start state when present.
    pure subroutine unknown_directions(self, y, dq, dp, dmu, dqa, dpa)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: y(:)
        real(wp), intent(out) :: dq(:, 0:), dp(:, 0:), dmu(:, 0:)
        real(wp), intent(in), optional :: dqa(:), dpa(:)
        integer :: i, base
        associate (lay => self%layout, n => self%n, m => self%m)
            dq(:, 0) = 0
            do i = 1, self%order_m
                base = lay%z_at(i)
                dq(:, i) = y(base + 1:base + n)
            end do
            do i = 0, self%order_n
                base = lay%w_at(i)
                dp(:, i) = y(base + 1:base + n)
            end do
            do i = 0, self%order_m
                base = lay%mu_at(i)
                dmu(:, i) = y(base + 1:base + m)
            end do
        end associate
        if (present(dqa)) dq = dq + spread(dqa, 2, size(dq, 2))
        if (present(dpa)) dp = dp + spread(dpa, 2, size(dp, 2))
    end subroutine unknown_directions

    !> Solve (Newton matrix) y = rhs with the real64 factors, refined with the exact
    !! product in working precision until the corrections stop shrinking (round-off of the
    !! product) or fall below epsilon (or the next one would: corrections shrink
    !! geometrically, so the one after c_k is about c_k^2 / c_(k-1)). Each refinement multiplies the error by about
    !! cond(F_x) epsilon(real64): a few refinements reach working precision unless the
    !! matrix is too ill-conditioned for real64 factors, which is refused.
    subroutine refined_solve(self, rhs, y, status)
        class(discrete_scheme), intent(in) :: self
        real(wp), intent(in) :: rhs(:)
        real(wp), intent(out) :: y(:)
        type(holosym_status_t), intent(out) :: status
        real(dp) :: correction(self%nx, 1)
        real(wp) :: product(self%nx), size_now, size_before, next
        integer :: refinement
        y = 0
        product = 0
        size_before = huge(1.0_wp)
        do refinement = 1, max_refinements
            correction(:, 1) = real(rhs - product, dp)
            call lu_solve_dp(self%lin_factors, self%lin_pivots, correction)
            y = y + real(correction(:, 1), wp)
            size_now = real(maxval(abs(correction)), wp)
            ! Converged (or the next correction, at this rate of contraction, would be),
            ! or no longer contracting (the product's round-off, or divergence).
            next = size_now
            if (refinement > 1) next = size_now * min(1.0_wp, size_now / size_before)
            if (next <= epsilon(1.0_wp) * maxval(abs(y)) .or. &
                size_now > refinement_contraction * size_before) exit
            size_before = size_now
            call self%linearised_product(y, product)
        end do
        if (size_now <= refined_accuracy * maxval(abs(y))) then
            call set_status(status, HOLOSYM_SUCCESS, "")
        else
            call set_status(status, HOLOSYM_SINGULAR_MATRIX, "the Newton matrix of the step " &
                // "is too ill-conditioned for the tangent map (the refinement stopped at a " &
                // "relative correction " // real_str(size_now / maxval(abs(y))) // ")")
        end if
    end subroutine refined_solve

end module holosym_scheme
