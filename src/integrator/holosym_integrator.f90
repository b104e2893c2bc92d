!> category: internal module (use holosym)
!! The integrator: set up with (M, N, G), advance a state by one step or many.
!!
!! `step` advances (q, p) by h in place and leaves them unchanged on failure.
!! `integrate` runs many steps with compensated summation of the increments (round-off
!! grows like the square root of the step count), reports each step to an optional
!! observer, and on failure keeps the state of the last good step.
!!
!! Speed options (components of the integrator; every path ends by iterating the same
!! working-precision residual to the same tolerance, so the results agree to round-off).
!! Defaults first; the second value gives the plain path (full Newton, working-precision
!! LU), which is also tried automatically when a fast solve fails:
!!
!! - `newton%simplified` (`.true.` | `.false.`): keep the factorised Jacobian across
!!   iterations and steps; refactor when a cost model says it pays.
!! - `linear_solver` (`'mixed'` | `'real128'`): a real64 Jacobian factored by LAPACK
!!   (iterative refinement of the working-precision residual), or the working-precision LU.
!! - `newton%presolve` (`.true.` | `.false.`, with `'mixed'`): first iterate the residual
!!   with the scheme's sums in real64 arithmetic, then refine in working precision.
!! - `linear_increments` (`.true.` | `.false.`): the step's results from the evaluation at
!!   the last Newton iterate, updated to first order across the last (tiny) correction,
!!   instead of one more evaluation at the solution.
!! - `jacobian` (`'assembled'` | `'residual-differences'`): from second derivatives, or
!!   differences of the residual (for checks).
!! - `hessians` (`'user'` | `'differences'`): the system's `hessian` bindings, or differences
!!   of its gradients.
!! - `extrapolate` (`.true.` | `.false.`): first guess from the previous step's polynomials.
!!
!! `'native'` is a synonym of `'real128'` and `'lapack'` of `'mixed'` (the name of the
!! default in the real64 build, `-DHOLOSYM_REAL64`). `stats` counts the work.
!!
!! At large h the step's equations can have several solutions, and Newton may converge to
!! one that is not the continuation of the flow; or h may be too large to resolve the
!! motion. With `check_roots` (default) a step whose energy changes by more than 1e-3 or
!! whose momentum polynomial misses its end momenta by more than the state's size is
!! accepted only when it lies within 1e-2 of two steps of h/2 (the root from the constant
!! first guess is tried as well), else it fails with HOLOSYM_STEP_TOO_LARGE. A failed step is reported with the code of its cause: h below
!! the resolution of the state (HOLOSYM_STEP_TOO_SMALL), constraints dependent at the
!! start or within the step (HOLOSYM_RANK_DEFICIENT_CONSTRAINTS), h too large for the
!! equations (HOLOSYM_STEP_TOO_LARGE), else the solver's own code. Every setting is
!! checked before a step (HOLOSYM_INVALID_ARGUMENT names it). Codes and limits:
!! docs/status-codes.md.
module holosym_integrator
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, &
        HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_SINGULAR_MATRIX, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
        HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_STEP_TOO_LARGE, &
        HOLOSYM_STEP_TOO_SMALL
    use holosym_problem, only: constrained_hamiltonian
    use holosym_newton, only: newton_settings_t, newton_report_t, newton_solve, &
        newton_workspace_t, all_finite, stagnation_floor, newton_settings_valid, &
        LINEAR_SOLVER_NATIVE, &
        LINEAR_SOLVER_MIXED
    use holosym_scheme, only: discrete_scheme, JACOBIAN_ASSEMBLED, &
        JACOBIAN_RESIDUAL_DIFFERENCES, HESSIANS_USER, HESSIANS_DIFFERENCES
    use holosym_manifold, only: manifold_residuals, manifold_tolerance_default, &
        full_rank_constraints, sparse_manifold_residuals, sparse_full_rank_constraints
    use holosym_reduced_step, only: reduced_step_t, reduced_report_t
    use holosym_reduced_scheme, only: reduced_structure
    use holosym_system_check, only: check_system, system_check_report_t
    implicit none
    private

    public :: constrained_integrator, step_info_t, step_observer, integrator_stats_t, &
        step_dense_output

    !> Default `linear_solver`: real64 LAPACK factors of a real64 Jacobian, refined with the
    !! working-precision residual ('lapack' names the same in the real64 build).
    character(len=*), parameter :: default_linear_solver = &
        trim(merge("lapack", "mixed ", wp_is_double))

    !> A step whose end state misses a constraint by more than this (scaled as in
    !! manifold_residuals) has not converged: sqrt(epsilon).
    real(wp), parameter :: end_state_tolerance = sqrt(epsilon(1.0_wp))
    !> ... or this many times a looser Newton tolerance (`newton%tolerance`).
    real(wp), parameter :: end_state_factor = 1024

    !> The reduced step falls back on the general one for systems with at most this many
    !! general unknowns (its dense workspace is then at most a few megabytes).
    integer, parameter :: general_fallback_size = 400

    !> A step whose energy changes by more than this, relative to |H| + |p . H_p| at the
    !! step, is checked (`check_roots`): the exact flow keeps H, so a larger change marks a
    !! spurious Newton root or a step too large to resolve the motion (in the paper's
    !! tables only the order-2 scheme at h = 1/2 changes it by more, at most 2e-3).
    real(wp), parameter :: root_energy_change = 1.0e-3_wp
    !> ... so is a step whose momentum polynomial ends farther than this, relative to the
    !! size of the state, from the step's end momenta (`momentum_jump`): at most 0.3 for
    !! the continuation of the flow in the paper's tables and on a double pendulum at
    !! h = 1/4, 4 to 40 at the spurious roots found on a double pendulum and on a charged
    !! particle on a sphere (h = 1/8 to 1).
    real(wp), parameter :: root_momentum_jump = 1
    !> ... and accepted when its end state is within this distance, relative to the size of
    !! the state, of two steps of h/2 (spurious roots land O(1) away; a farther step does
    !! not resolve the motion either).
    real(wp), parameter :: root_distance = 1.0e-2_wp
    !> A singular Newton matrix is put down to the constraints when Phi Phi^T has a relative
    !! pivot below this, at the step's start or at a node of the iterate (singular values
    !! of Phi below epsilon**(1/4) relative): there they are nearly dependent, and their
    !! multipliers are determined to no digit in real64 and to few in working precision.
    real(wp), parameter :: dependence_threshold = sqrt(epsilon(1.0_wp))
    !> Factor on the nominal resolution limit of a state (`resolution_limit`): the step's
    !! equations amplify the round-off of q; on the pendulums Newton fails from h = 1e-11
    !! (real128) where the nominal limit is 6e-12, and never from 3e-11 on.
    real(wp), parameter :: resolution_margin = 64
    !> A singular step whose Newton matrix at the constant guess is this many times better
    !! conditioned (pivot ratio) at h/16 than at h is too large: beyond the system's time
    !! scale the ratio falls like 1/h (16 times per factor 16), below it it rises with h.
    real(wp), parameter :: large_step_gain = 4

    !> What one step did and how well the constraints hold after it.
    type :: step_info_t
        !> Newton iterations of the step.
        integer :: newton_iterations = 0
        !> max |phi| over the step's displacement nodes q_0..q_M.
        real(wp) :: constraint_residual = 0
        !> max |Phi(q_b) H_p(q_b, p_b)| at the step end (hidden constraint).
        real(wp) :: velocity_residual = 0
        !> Smallest relative pivot of the (row-equilibrated) Newton Jacobian.
        real(wp) :: pivot_ratio = 0
        !> Multipliers lambda_k at the displacement nodes, m x (0:M).
        real(wp), allocatable :: lambda(:, :)
        !> Residual evaluations of the step (including residual-difference Jacobians).
        integer :: residual_evaluations = 0
        !> Residual evaluations in real64 arithmetic (`newton%presolve`) of the step.
        integer :: lowered_residual_evaluations = 0
        !> Jacobian evaluations (= LU factorisations) of the step.
        integer :: lu_factorizations = 0
        !> Calls of dh_dq or dh_dp in the step (difference Hessians count 6n each).
        integer :: gradient_evaluations = 0
        !> Calls of hessian or constraint_hessian in the step.
        integer :: hessian_evaluations = 0
    end type step_info_t

    !> Work done since `init` (or `reset_statistics`), summed over successful and failed
    !! Newton solves.
    type :: integrator_stats_t
        !> Completed steps.
        integer(int64) :: steps = 0
        !> Newton iterations.
        integer(int64) :: newton_iterations = 0
        !> Residual evaluations (including those of residual-difference Jacobians).
        integer(int64) :: residual_evaluations = 0
        !> Residual evaluations in real64 arithmetic (`newton%presolve`).
        integer(int64) :: lowered_residual_evaluations = 0
        !> Jacobian evaluations.
        integer(int64) :: jacobian_evaluations = 0
        !> LU factorisations (real128 or real64).
        integer(int64) :: lu_factorizations = 0
        !> Calls of dh_dq or dh_dp (difference Hessians count 6n each).
        integer(int64) :: gradient_evaluations = 0
        !> Calls of hessian or constraint_hessian.
        integer(int64) :: hessian_evaluations = 0
    end type integrator_stats_t

    !> The dense output of the step that `integrate` has just taken: q~, p~ and lambda~ at
    !! any time of [t_start, t_end]. `integrate` sets an observer's `dense` component to it
    !! before each call of `observe`, so output at times off the step grid needs no loop of
    !! single steps. Valid only inside `observe`; elsewhere `evaluate` fails with
    !! HOLOSYM_NOT_INITIALIZED.
    type :: step_dense_output
        !> Time at the start of the step.
        real(wp) :: t_start = 0
        !> Time at its end (t_start + h).
        real(wp) :: t_end = 0
        class(constrained_integrator), pointer, private :: integrator => null()
    contains
        !> q~(t), p~(t), lambda~(t) for t in [t_start, t_end].
        procedure :: evaluate => dense_evaluate
        !> Whether the evaluator refers to a step (inside `observe` of `integrate`).
        procedure :: available => dense_available
    end type step_dense_output

    !> The numbers of a solved step that is not accepted yet (see `commit_step`).
    type :: pending_t
        logical :: general = .true.       ! solved by the general scheme (else the reduced)
        logical :: extrapolated = .false. ! from the extrapolated first guess
        integer :: iterations = 0, factorizations = 0, residuals = 0, lowered = 0
        integer :: gradients = 0, hessians = 0
        real(wp) :: pivot_ratio = 0
        real(wp) :: velocity = 0          ! max |Phi H_p| at the end state
        real(wp) :: position = 0          ! max |phi| over the displacement nodes
        real(wp) :: energy = 0            ! H at the end state (when `energy_known`)
        logical :: energy_known = .false.
        logical :: energy_finite = .true. ! H finite at both ends (see `energy_change`)
        real(wp) :: energy_change = 0     ! see `energy_change`
        real(wp) :: momentum_jump = 0     ! see `momentum_jump`
    end type pending_t

    !> A solved step set aside while another root is tried (`verify_root`).
    type :: step_candidate_t
        type(pending_t) :: pending
        real(wp), allocatable :: x(:)      ! the solution (general or reduced unknowns)
        real(wp), allocatable :: dq(:), dp(:)
    end type step_candidate_t

    !> Receives every step of `integrate`. Extend it; keep your data as components.
    type, abstract :: step_observer
        !> The dense output of the step just taken, set by `integrate` before each call of
        !! `observe` (e.g. `call self%dense%evaluate(t, q, p, lambda)` for t between
        !! `self%dense%t_start` and `self%dense%t_end`).
        type(step_dense_output) :: dense
    contains
        !> Called after step k (t = start_time + k h) with the new state; set `halt` to stop.
        procedure(observe_interface), deferred :: observe
    end type step_observer

    abstract interface
        subroutine observe_interface(self, step, t, q, p, info, halt)
            import :: step_observer, wp, step_info_t
            class(step_observer), intent(inout) :: self !! the observer
            integer, intent(in) :: step          !! step number k >= 1 within this run
            real(wp), intent(in) :: t            !! time start_time + k h
            real(wp), intent(in) :: q(:)         !! coordinates after the step
            real(wp), intent(in) :: p(:)         !! momenta after the step
            type(step_info_t), intent(in) :: info !! diagnostics of the step
            logical, intent(inout) :: halt       !! set .true. to stop after this step
        end subroutine observe_interface
    end interface

    !> The symplectic integrator of a constrained Hamiltonian system for one (M, N, G).
    type :: constrained_integrator
        !> Newton tolerances and limits (defaults from epsilon); simplified Newton and the
        !! real64 pre-solve are on by default.
        type(newton_settings_t) :: newton = newton_settings_t(simplified=.true., presolve=.true.)
        !> Start Newton from the previous step's polynomials when the state continues it.
        logical :: extrapolate = .true.
        !> LU of the Newton Jacobian: 'real128' (working precision) or 'mixed' (real64 LAPACK).
        character(len=16) :: linear_solver = default_linear_solver
        !> Newton Jacobian: 'assembled' (second derivatives) or 'residual-differences'.
        character(len=24) :: jacobian = "assembled"
        !> Second derivatives: 'user' (the system's bindings) or 'differences' (of gradients).
        character(len=16) :: hessians = "user"
        !> Step results from the last iterate's evaluation updated to first order (saves an
        !! evaluation per step) instead of a new evaluation at the solution.
        logical :: linear_increments = .true.
        !> Work counters since init (read them; `reset_statistics` zeroes them).
        type(integrator_stats_t) :: stats
        !> Largest scaled residual of an accepted start state (see manifold_residuals).
        real(wp) :: manifold_tolerance = manifold_tolerance_default
        !> Use the reduced step (momenta eliminated, sparse linear algebra) when the system
        !! declares a constant diagonal mass matrix (`diagonal_mass`); read by `init`.
        logical :: structured = .true.
        !> Check every step for a spurious Newton root or a step too large to resolve the
        !! motion: a step that changes the energy by more than 1e-3 (relative to
        !! |H| + |p . H_p|), or whose momentum polynomial misses the end momenta by more
        !! than the state's size, is accepted only when it lies within 1e-2 (relative to the
        !! state's size) of two steps of h/2 (the root from the constant first guess is
        !! tried too); else it fails with HOLOSYM_STEP_TOO_LARGE. Costs one call of H per
        !! step.
        logical :: check_roots = .true.
        !> Check the system's procedures and declarations against each other
        !! (`check_system`: gradients against differences of H, Phi against differences of
        !! phi, Hessians, a declared mass, declared sparsity patterns) at the first start
        !! state after `init`; a system that fails is refused with
        !! HOLOSYM_INCONSISTENT_SYSTEM naming the procedure and the entry. Costs a few
        !! dozen evaluations of each procedure once (docs/user_system.md has the measured
        !! cost); `.false.` skips it.
        logical :: check_system = .true.
        ! The check of the system has passed since `init`.
        logical, private :: system_checked = .false.
        ! `structured` as `init` read it (a change after init is refused, not ignored).
        logical, private :: structured_at_init = .true.
        type(discrete_scheme), private :: scheme
        type(reduced_step_t), private :: reduced
        logical, private :: reduced_active = .false.
        ! The general scheme is set up: the main path, or the reduced path's fallback.
        logical, private :: general_ready = .false.
        ! The last step was solved by the general scheme (its dense output, extrapolation).
        logical, private :: last_general = .true.
        logical, private :: ready = .false.
        logical, private :: have_last = .false.
        real(wp), allocatable, private :: last_x(:), last_qa(:), last_pa(:)
        real(wp), allocatable, private :: last_qb(:), last_pb(:)
        real(wp), private :: last_h = 0
        type(step_info_t), private :: last_info
        ! Preallocated workspace: inside `integrate` a step allocates only its status
        ! message and the four small arrays of the end-state check (manifold_residuals).
        type(newton_workspace_t), private :: workspace
        real(wp), private :: workspace_h = 0
        integer, private :: applied_modes(3) = 0
        real(wp), allocatable, private :: x_work(:), dq_work(:), dp_work(:)
        real(wp), allocatable, private :: q_end_work(:), p_end_work(:), hp_work(:)
        ! The step solved by the last attempt, before it is accepted.
        type(pending_t), private :: pending
        ! H at the end of the last accepted step, for the next step's energy check.
        real(wp), private :: last_energy = 0
        logical, private :: last_energy_known = .false.
        ! Why the Newton matrix of the failing attempts was singular, when the constraints
        ! are dependent at a displacement node of the iterate ("" otherwise).
        character(len=:), allocatable, private :: dependent_nodes
    contains
        !> Set up for a system and (M, N, G).
        procedure :: init => integrator_init
        !> One step of size h, in place.
        procedure :: step => integrator_step
        !> Many steps of size h, in place, with an optional observer.
        procedure :: integrate => integrator_integrate
        !> q~, p~, lambda~ of the last step at tau in [0, 1].
        procedure :: dense_output => integrator_dense_output
        !> Diagnostics of the last successful step.
        procedure :: last_step => integrator_last_step
        !> (M, N, G) of the scheme.
        procedure :: orders => integrator_orders
        !> Zero the work counters `stats`.
        procedure :: reset_statistics => integrator_reset_statistics
    end type constrained_integrator


    !> What the off-manifold messages advise.
    character(len=*), parameter :: onto_manifold = "put it on the manifold with " // &
        "project_to_manifold (from q and p) or state_from_velocities (from q and dq/dt)"
contains

    !> Set up the integrator for `sys` (its sizes n, m) and the scheme (M, N, G), e.g.
    !! `call integ%init(sys, M=2, N=1, G=3, status=status)`.
    !! Codes: HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION.
    subroutine integrator_init(self, sys, M, N, G, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system (only n, m are read)
        integer, intent(in) :: M !! M >= 1, degree of the displacement polynomial
        integer, intent(in) :: N !! N >= 0, degree of the momentum polynomial
        integer, intent(in) :: G !! G >= 1, Gauss points (G = max(M, N) + 1 typical)
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(discrete_scheme) :: scheme
        type(holosym_status_t) :: local
        real(wp), allocatable :: mass(:)
        integer :: nx

        ! Checks of (M, N, G) and of the sizes are the general scheme's.
        call scheme%check(M, N, G, sys%n, sys%m, local)
        self%reduced_active = .false.
        self%structured_at_init = self%structured
        if (local%ok() .and. self%structured) then
            allocate (mass(sys%n))
            self%reduced_active = reduced_structure(sys, mass)
        end if
        if (local%ok() .and. self%reduced_active) &
            call self%reduced%init(sys, M, N, G, local)
        ! The general scheme's workspace is dense (cubic in the size): as the reduced step's
        ! fallback only for small systems.
        self%general_ready = .not. self%reduced_active .or. &
            scheme%nx <= general_fallback_size
        if (local%ok() .and. self%general_ready) &
            call scheme%init(M, N, G, sys%n, sys%m, local)
        if (.not. local%ok()) then
            self%ready = .false.
            call set_status(status, local%code, local%message)
            return
        end if
        self%scheme = scheme
        self%ready = .true.
        self%system_checked = .false.
        self%have_last = .false.
        if (allocated(self%last_info%lambda)) deallocate (self%last_info%lambda)
        allocate (self%last_info%lambda(sys%m, 0:M))
        self%last_info%lambda = 0
        if (allocated(self%x_work)) deallocate (self%x_work, self%dq_work, self%dp_work, &
                                                self%q_end_work, self%p_end_work, self%hp_work)
        if (allocated(self%last_x)) deallocate (self%last_x, self%last_qa, self%last_pa, &
                                                self%last_qb, self%last_pb)
        nx = scheme%nx
        if (.not. self%general_ready) nx = 0
        allocate (self%x_work(nx), self%dq_work(sys%n), self%dp_work(sys%n), &
                  self%q_end_work(sys%n), self%p_end_work(sys%n), self%hp_work(sys%n))
        self%last_energy_known = .false.
        self%dependent_nodes = ""
        allocate (self%last_x(nx), self%last_qa(sys%n), self%last_pa(sys%n), &
                  self%last_qb(sys%n), self%last_pb(sys%n))
        ! A fresh workspace: nothing learnt by an earlier run (kept factors, the
        ! quadratic-convergence constant) may change the results of this one.
        self%workspace = newton_workspace_t()
        if (self%general_ready) call self%workspace%setup(scheme%nx)
        self%last_general = .not. self%reduced_active
        self%applied_modes = 0
        self%stats = integrator_stats_t()
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine integrator_init

    !> (M, N, G) of the initialised scheme (zeros before `init`).
    pure subroutine integrator_orders(self, M, N, G)
        class(constrained_integrator), intent(in) :: self
        integer, intent(out) :: M !! degree of the displacement polynomial
        integer, intent(out) :: N !! degree of the momentum polynomial
        integer, intent(out) :: G !! Gauss points
        M = self%scheme%order_m
        N = self%scheme%order_n
        G = self%scheme%gauss_points
    end subroutine integrator_orders

    !> Check everything a step needs before touching the state.
    subroutine validate(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(out) :: status
        real(wp) :: position, velocity, scaled_position, scaled_velocity, tolerance, hp(size(q))
        character(len=:), allocatable :: rank_message
        logical :: continuing, finite

        if (.not. self%ready) then
            call set_status(status, HOLOSYM_NOT_INITIALIZED, "call init before step or integrate")
        else if (.not. settings_valid(self, rank_message)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, rank_message)
        else if (self%structured .neqv. self%structured_at_init) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "structured was changed " // &
                "after init, which reads it (it chooses the path); call init again")
        else if (sys%n /= self%scheme%n .or. sys%m /= self%scheme%m) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "system has n = " // int_str(sys%n) &
                // ", m = " // int_str(sys%m) // " but the integrator was set up for n = " // &
                int_str(self%scheme%n) // ", m = " // int_str(self%scheme%m))
        else if (size(q) /= sys%n .or. size(p) /= sys%n) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q and p must have size n = " // &
                int_str(sys%n) // "; got " // int_str(size(q)) // " and " // int_str(size(p)))
        else if (.not. is_finite(h)) then
            call set_status(status, HOLOSYM_INVALID_STEP_SIZE, "step size must be positive and " &
                // "finite; got h = " // real_str(h))
        else if (h <= 0) then
            call set_status(status, HOLOSYM_INVALID_STEP_SIZE, "step size must be positive and " &
                // "finite; got h = " // real_str(h))
        else if (h < tiny(h)) then
            ! 1/h would overflow: far below the resolution of any state.
            call set_status(status, HOLOSYM_STEP_TOO_SMALL, "step size h = " // real_str(h) // &
                " is below the smallest normal number " // real_str(tiny(h)) // &
                " and below the resolution of any state")
        else if (.not. (all(is_finite(q)) .and. all(is_finite(p)))) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "q or p contains NaN or Inf")
        else
            ! The end state of this integrator's last step passed its end-state check: as
            ! the next start it needs no rank test (step-by-step callers do not pay one per
            ! step) and meets the end-state tolerance (looser than `manifold_tolerance` when
            ! the Newton tolerance is).
            continuing = continues_last_step(self, q, p)
            tolerance = self%manifold_tolerance
            if (continuing) tolerance = max(tolerance, end_tolerance(self))
            if (.not. continuing) then
                ! An energy beyond the range of the numbers (e.g. |p| = 1e4000) first: every
                ! later test would only see its effects.
                if (.not. is_finite(sys%hamiltonian(q, p))) then
                    call set_status(status, HOLOSYM_NONFINITE_VALUE, "hamiltonian returned " &
                        // "NaN or Inf at the start state")
                    return
                end if
                ! The system's own consistency next: a wrong declaration (a sparsity
                ! pattern, a Jacobian) would make every later test report its effect.
                call check_once(self, sys, q, p, status)
                if (.not. status%ok()) return
                if (.not. rank_test(self, sys, q, rank_message, finite=finite)) then
                    call set_status(status, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, rank_message)
                    return
                else if (.not. finite) then
                    call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint_jacobian " // &
                        "returned NaN or Inf at the start state")
                    return
                end if
            end if
            call state_residuals(self, sys, q, p, position, velocity, scaled_position, &
                                 scaled_velocity, hp)
            if (.not. (is_finite(scaled_position) .and. is_finite(scaled_velocity))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, &
                    "constraint, constraint_jacobian " &
                    // "or dh_dp returned NaN or Inf at the start state")
            else if (scaled_position > tolerance) then
                call set_status(status, HOLOSYM_OFF_MANIFOLD, "start state violates the " // &
                    "constraints: max|phi| = " // real_str(position) // " (scaled " // &
                    real_str(scaled_position) // " > tolerance " // &
                    real_str(tolerance) // "); " // onto_manifold)
            else if (scaled_velocity > tolerance) then
                call set_status(status, HOLOSYM_OFF_MANIFOLD, &
                    "start state violates the hidden " // &
                    "constraint: max|Phi H_p| = " // real_str(velocity) // " (scaled " // &
                    real_str(scaled_velocity) // " > tolerance " // &
                    real_str(tolerance) // "); " // onto_manifold)
            else if (h < epsilon(h) * state_resolution(self, q, p, hp)) then
                ! Far below the resolution: the step would move nothing, and its equations
                ! would overflow (1/h) in the real64 parts of the solve.
                call set_status(status, HOLOSYM_STEP_TOO_SMALL, "step size h = " // &
                    real_str(h) // " is far below the resolution of this state (about h = " &
                    // real_str(state_resolution(self, q, p, hp)) // "); use h >= that")
            else
                call set_status(status, HOLOSYM_SUCCESS, "")
            end if
        end if
    end subroutine validate

    !> The check of the system (`check_system` setting) at the first start state after
    !! `init`: its failure is the call's.
    subroutine check_once(self, sys, q, p, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        type(holosym_status_t), intent(out) :: status
        type(system_check_report_t) :: report
        call set_status(status, HOLOSYM_SUCCESS, "")
        if (.not. self%check_system .or. self%system_checked) return
        call check_system(sys, q, p, report, status)
        if (status%ok()) self%system_checked = .true.
    end subroutine check_once

    !> Whether every setting of the integrator is in its range; `message` names the first
    !! that is not: the Newton settings (`newton_settings_valid`), 0 < manifold_tolerance < 1
    !! (finite) and the option strings.
    logical function settings_valid(self, message)
        class(constrained_integrator), intent(in) :: self
        character(len=:), allocatable, intent(out) :: message
        if (newton_settings_valid(self%newton, message)) then
            ! Finiteness first: a NaN in an ordered comparison raises 'invalid'.
            if (.not. is_finite(self%manifold_tolerance)) then
                message = "manifold_tolerance must be finite, got " // &
                    real_str(self%manifold_tolerance)
            else if (self%manifold_tolerance <= 0 .or. self%manifold_tolerance >= 1) then
                message = "manifold_tolerance must be in (0, 1), got " // &
                    real_str(self%manifold_tolerance)
            end if
        end if
        if (len(message) == 0) then
            select case (self%linear_solver)
            case ("real128", "native", "mixed", "lapack")
            case default
                message = "linear_solver must be 'real128' or 'mixed'; got '" // &
                    trim(self%linear_solver) // "'"
            end select
        end if
        if (len(message) == 0) then
            select case (self%jacobian)
            case ("assembled", "residual-differences")
            case default
                message = "jacobian must be 'assembled' or 'residual-differences'; got '" // &
                    trim(self%jacobian) // "'"
            end select
        end if
        if (len(message) == 0) then
            select case (self%hessians)
            case ("user", "differences")
            case default
                message = "hessians must be 'user' or 'differences'; got '" // &
                    trim(self%hessians) // "'"
            end select
        end if
        settings_valid = len(message) == 0
    end function settings_valid

    !> Largest scaled constraint residual of an accepted end state: `end_state_tolerance`,
    !! or `end_state_factor` times a looser Newton tolerance.
    pure real(wp) function end_tolerance(self)
        class(constrained_integrator), intent(in) :: self
        end_tolerance = max(end_state_tolerance, end_state_factor * self%newton%tolerance)
    end function end_tolerance

    !> `manifold_residuals`, through Phi's sparse pattern on the reduced path.
    subroutine state_residuals(self, sys, q, p, position, velocity, scaled_position, &
                               scaled_velocity, velocity_field)
        class(constrained_integrator), intent(in) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: position, velocity, scaled_position, scaled_velocity
        real(wp), intent(out), optional :: velocity_field(:) !! H_p(q, p)
        if (self%reduced_active) then
            call sparse_manifold_residuals(sys, self%reduced%scheme%layout%phi_rows, &
                self%reduced%scheme%layout%phi_cols, q, p, position, velocity, &
                scaled_position, scaled_velocity, velocity_field)
        else
            call manifold_residuals(sys, q, p, position, velocity, scaled_position, &
                                    scaled_velocity, velocity_field)
        end if
    end subroutine state_residuals

    !> `full_rank_constraints`, banded through Phi's sparse pattern on the reduced path.
    logical function rank_test(self, sys, q, message, threshold, finite)
        class(constrained_integrator), intent(in) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:)
        character(len=:), allocatable, intent(out) :: message
        real(wp), intent(in), optional :: threshold !! relative pivot of Phi Phi^T
        logical, intent(out), optional :: finite    !! false: Phi not finite (result true)
        if (self%reduced_active) then
            associate (lay => self%reduced%scheme%layout)
                rank_test = sparse_full_rank_constraints(sys, lay%phi_rows, lay%phi_cols, &
                                                         lay%constraint_order, q, message, &
                                                         threshold, finite)
            end associate
        else
            rank_test = full_rank_constraints(sys, q, message, threshold, finite)
        end if
    end function rank_test

    !> Zero the work counters `stats`.
    subroutine integrator_reset_statistics(self)
        class(constrained_integrator), intent(inout) :: self
        self%stats = integrator_stats_t()
    end subroutine integrator_reset_statistics

    !> Translate the option strings into the modes of the scheme and the Newton workspace.
    !! Code HOLOSYM_INVALID_ARGUMENT names an unknown value.
    subroutine apply_options(self, h, status)
        class(constrained_integrator), intent(inout) :: self
        real(wp), intent(in) :: h
        type(holosym_status_t), intent(inout) :: status
        integer :: modes(3)
        select case (self%linear_solver)
        case ("real128", "native")
            modes(1) = LINEAR_SOLVER_NATIVE
        case ("mixed", "lapack")
            modes(1) = LINEAR_SOLVER_MIXED
        case default
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "linear_solver must be " // &
                "'real128' or 'mixed'; got '" // trim(self%linear_solver) // "'")
            return
        end select
        select case (self%jacobian)
        case ("assembled")
            modes(2) = JACOBIAN_ASSEMBLED
        case ("residual-differences")
            modes(2) = JACOBIAN_RESIDUAL_DIFFERENCES
        case default
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "jacobian must be " // &
                "'assembled' or 'residual-differences'; got '" // trim(self%jacobian) // "'")
            return
        end select
        select case (self%hessians)
        case ("user")
            modes(3) = HESSIANS_USER
        case ("differences")
            modes(3) = HESSIANS_DIFFERENCES
        case default
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "hessians must be 'user' or " // &
                "'differences'; got '" // trim(self%hessians) // "'")
            return
        end select
        ! Kept factors belong to one step size and one way of forming the Jacobian.
        if (any(modes /= self%applied_modes) .or. h /= self%workspace_h) then
            call self%workspace%invalidate()
            self%applied_modes = modes
            self%workspace_h = h
        end if
        self%workspace%linear_solver = modes(1)
        self%scheme%jacobian_mode = modes(2)
        self%scheme%hessian_mode = modes(3)
        self%scheme%linear_increments = self%linear_increments
    end subroutine apply_options

    !> True when (q, p) is exactly the end state of the last successful step.
    pure logical function continues_last_step(self, q, p)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        continues_last_step = .false.
        if (self%have_last) continues_last_step = all(q == self%last_qb) .and. &
            all(p == self%last_pb)
    end function continues_last_step

    !> True when any of the Newton speed options is in use.
    pure logical function fast_options(self)
        class(constrained_integrator), intent(in) :: self
        fast_options = self%newton%simplified .or. self%newton%presolve .or. &
            (self%linear_solver /= "real128" .and. self%linear_solver /= "native")
    end function fast_options

    !> `settings` with the speed options of Newton's method off.
    pure function plain_settings(settings) result(plain)
        type(newton_settings_t), intent(in) :: settings
        type(newton_settings_t) :: plain
        plain = settings
        plain%simplified = .false.
        plain%presolve = .false.
    end function plain_settings

    !> One step from (q, p), which stay unchanged: solve (`attempt_step`), check the root
    !! (`energy_change`, `verify_root`) and accept it (`commit_step`: the increments in
    !! self%dq_work, self%dp_work, the step's data in self%last_*). On failure the code
    !! says why (`diagnose_failure`) and the last accepted step stays the last step.
    subroutine solve_step(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(out) :: status
        self%dependent_nodes = ""
        call attempt_step(self, sys, q, p, h, .true., status)
        if (.not. status%ok()) then
            call diagnose_failure(self, sys, q, p, h, status)
            return
        end if
        if (self%check_roots) then
            if (suspicious(self, sys, q, p, h)) then
                call verify_root(self, sys, q, p, h, status)
                return
            end if
            if (.not. self%pending%energy_finite) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, trim(step_label(self, h)) // &
                    ": hamiltonian returned NaN or Inf at the start or the end of the step")
                return
            end if
        end if
        call commit_step(self, sys, q, p, h, .false.)
    end subroutine solve_step

    !> Whether the solved step may be a spurious Newton root: its energy change exceeds
    !! `root_energy_change` or its momentum polynomial jumps by more than
    !! `root_momentum_jump` (`energy_change`, `momentum_jump`; both are recorded).
    logical function suspicious(self, sys, q, p, h)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), h
        self%pending%energy_change = energy_change(self, sys, q, p)
        self%pending%momentum_jump = momentum_jump(self, q, p, h)
        suspicious = self%pending%energy_change > root_energy_change .or. &
            self%pending%momentum_jump > root_momentum_jump
    end function suspicious

    !> max(|p~(0) - p_a|, |p~(1) - p_b|) / max(|q|, |p|) of the solved step: the ends of
    !! its momentum polynomial against its end momenta, relative to the state's size.
    function momentum_jump(self, q, p, h) result(jump)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:), h
        real(wp) :: jump, scale
        if (self%pending%general) then
            jump = self%scheme%momentum_jump(self%x_work, self%dp_work)
        else
            jump = self%reduced%scheme%momentum_jump(self%reduced%x, p, self%dp_work, h)
        end if
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (scale > 0) jump = jump / scale
        if (.not. is_finite(jump)) jump = 0
    end function momentum_jump

    !> Solve the step from (q, p) without accepting it: the reduced step when active (the
    !! general scheme its fallback for small systems), else the general scheme. With
    !! `extrapolation` false both start from the constant first guess.
    subroutine attempt_step(self, sys, q, p, h, extrapolation, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: extrapolation
        type(holosym_status_t), intent(out) :: status
        character(len=:), allocatable :: reduced_message
        if (.not. self%reduced_active) then
            call solve_general(self, sys, q, p, h, extrapolation, status)
        else
            call solve_reduced(self, sys, q, p, h, extrapolation, status)
            if (.not. (status%ok() .or. .not. self%general_ready .or. &
                       status%code == HOLOSYM_NONFINITE_VALUE)) then
                ! The reduced step factors its Newton matrix in real64 only: where that is
                ! too ill-conditioned (nearly dependent constraints), the general step of a
                ! small system has working-precision factors to fall back on (from the
                ! constant guess).
                reduced_message = status%message
                call solve_general(self, sys, q, p, h, .false., status)
                if (.not. status%ok()) &
                    status%message = status%message // " (after the " // reduced_message // ")"
            end if
        end if
        if (status%ok()) call node_residual(self, sys, q, h, status)
    end subroutine attempt_step

    !> max |phi| over the displacement nodes of the solved step, into `pending`; or
    !! HOLOSYM_NONFINITE_VALUE when `constraint` returns NaN or Inf at one of them (found by
    !! classification: no comparison with a NaN).
    subroutine node_residual(self, sys, q, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), h
        type(holosym_status_t), intent(inout) :: status
        real(wp) :: phi(sys%m)
        integer :: i
        self%pending%position = 0
        if (sys%m == 0) return
        do i = 0, self%scheme%order_m
            ! The node in p_end_work, free until `energy_change`.
            if (self%pending%general) then
                call self%scheme%solution_node(self%x_work, i, self%p_end_work)
            else
                self%p_end_work = q
                if (i > 0) self%p_end_work = q + &
                    self%reduced%x(self%reduced%scheme%layout%z_col(:, i))
            end if
            call sys%constraint(self%p_end_work, phi)
            if (.not. all(is_finite(phi))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, trim(step_label(self, h)) // &
                    ": constraint returned NaN or Inf at displacement node " // int_str(i) // &
                    " of the solved step")
                return
            end if
            self%pending%position = max(self%pending%position, maxval(abs(phi)))
        end do
    end subroutine node_residual

    !> Accept the step solved by the last attempt (or restored by `restore_candidate`):
    !! it becomes the last step (dense output, extrapolation, `last_step`). `rebind` binds
    !! the general scheme to this step again (after other attempts).
    subroutine commit_step(self, sys, q, p, h, rebind)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: rebind
        if (self%pending%general) then
            if (rebind) call self%scheme%set_step(sys, q, p, h)
            call self%scheme%node_values(self%x_work, self%last_info%lambda)
            self%last_x = self%x_work
        else
            call self%reduced%accept(q, h)
            call self%reduced%scheme%multipliers(self%reduced%last_x, h, self%last_info%lambda)
        end if
        self%last_general = self%pending%general
        associate (info => self%last_info, pending => self%pending)
            info%newton_iterations = pending%iterations
            info%constraint_residual = pending%position
            info%velocity_residual = pending%velocity
            info%pivot_ratio = pending%pivot_ratio
            info%lu_factorizations = pending%factorizations
            info%residual_evaluations = pending%residuals
            info%lowered_residual_evaluations = pending%lowered
            info%gradient_evaluations = pending%gradients
            info%hessian_evaluations = pending%hessians
        end associate
        self%last_qa = q
        self%last_pa = p
        self%last_h = h
        self%last_qb = q + self%dq_work
        self%last_pb = p + self%dp_work
        self%last_energy = self%pending%energy
        self%last_energy_known = self%pending%energy_known
        self%have_last = .true.
        self%stats%steps = self%stats%steps + 1
    end subroutine commit_step

    !> Relative energy change of the solved step, |H(q_b, p_b) - H(q_a, p_a)| /
    !! (|H(q_a, p_a)| + |p_b . H_p(q_b, p_b)|) with q_b = q + dq_work, p_b = p + dp_work
    !! (H(q_a, p_a) from the last step when the state continues it; H_p(q_b, p_b) from
    !! the solve's end-state check, in hp_work). H(q_b, p_b) is kept for the next step.
    !! 0 when a value is not finite (nothing to compare; `pending%energy_finite` says
    !! whether H was).
    function energy_change(self, sys, q, p) result(change)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: change
        real(wp) :: start, finish, power
        if (self%last_energy_known .and. continues_last_step(self, q, p)) then
            start = self%last_energy
        else
            start = sys%hamiltonian(q, p)
        end if
        ! H_p(q_b, p_b) is in hp_work from the end-state check of the solve.
        self%q_end_work = q + self%dq_work
        self%p_end_work = p + self%dp_work
        finish = sys%hamiltonian(self%q_end_work, self%p_end_work)
        power = abs(sum(self%p_end_work * self%hp_work))
        self%pending%energy = finish
        self%pending%energy_known = is_finite(finish)
        self%pending%energy_finite = is_finite(start) .and. is_finite(finish)
        change = 0
        if (.not. (is_finite(start) .and. is_finite(finish) .and. is_finite(power))) return
        if (abs(start) + power > 0) then
            change = abs(finish - start) / (abs(start) + power)
        else if (finish /= start) then
            change = huge(1.0_wp)
        end if
    end function energy_change

    !> The step changed the energy by more than `root_energy_change` (or its momentum
    !! polynomial jumps): Newton may have found a root that is not the continuation of the
    !! flow, or h may be too large to resolve it. Reference: two steps of h/2 from the
    !! constant guess. Candidates: the root found, and (when that came from the
    !! extrapolated guess) the root from the constant guess. The candidate within
    !! `root_distance` of the reference (the closest) is accepted; without a reference, the
    !! constant-guess root when its energy change is small. Otherwise the step fails with
    !! HOLOSYM_STEP_TOO_LARGE.
    subroutine verify_root(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(out) :: status
        type(step_candidate_t) :: first, second
        type(holosym_status_t) :: local
        real(wp) :: q_half(size(q)), p_half(size(p)), scale, distance(2)
        logical :: half_ok, have_second, second_suspicious, had_last
        integer :: chosen
        character(len=:), allocatable :: message

        had_last = self%have_last
        call take_candidate(self, first)
        ! Reference: two half steps, each from the constant guess.
        call attempt_step(self, sys, q, p, h / 2, .false., local)
        half_ok = local%ok()
        if (half_ok) then
            q_half = q + self%dq_work
            p_half = p + self%dp_work
            call attempt_step(self, sys, q_half, p_half, h / 2, .false., local)
            half_ok = local%ok()
            if (half_ok) then
                q_half = q_half + self%dq_work
                p_half = p_half + self%dp_work
            end if
        end if
        ! The other root, last: when chosen it is accepted as solved.
        have_second = .false.
        if (first%pending%extrapolated) then
            call attempt_step(self, sys, q, p, h, .false., local)
            if (local%ok()) then
                ! Records the candidate's energy change and momentum jump.
                second_suspicious = suspicious(self, sys, q, p, h)
                call take_candidate(self, second)
                have_second = .true.
            end if
        end if
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (.not. scale > 0) scale = 1
        distance = huge(1.0_wp)
        if (half_ok) then
            distance(1) = max(maxval(abs(first%dq + q - q_half)), &
                              maxval(abs(first%dp + p - p_half))) / scale
            if (have_second) distance(2) = max(maxval(abs(second%dq + q - q_half)), &
                                                maxval(abs(second%dp + p - p_half))) / scale
        end if
        chosen = 0
        if (half_ok) then
            if (distance(1) <= root_distance) chosen = 1
            if (have_second .and. distance(2) <= root_distance) then
                if (chosen == 0) then
                    chosen = 2
                else if (distance(2) < distance(1)) then
                    chosen = 2
                end if
            end if
        else if (have_second) then
            if (.not. second_suspicious) chosen = 2
        end if
        select case (chosen)
        case (1)
            call restore_candidate(self, first)
            call commit_step(self, sys, q, p, h, .true.)
            call set_status(status, HOLOSYM_SUCCESS, "")
        case (2)
            call restore_candidate(self, second)
            call commit_step(self, sys, q, p, h, .true.)
            call set_status(status, HOLOSYM_SUCCESS, "")
        case default
            message = trim(step_label(self, h)) // ": the step is too large (a spurious " // &
                "Newton root, or a step that does not resolve the motion): Newton's root " // &
                "changes the energy by " // &
                real_str(first%pending%energy_change) // " (relative; checked above " // &
                real_str(root_energy_change) // "), its momentum polynomial misses the end " // &
                "momenta by " // real_str(first%pending%momentum_jump) // " (checked above " // &
                real_str(root_momentum_jump) // ")"
            if (half_ok) then
                message = message // " and it lies " // real_str(distance(1)) // &
                    " (relative) from two steps of h/2 (accepted within " // &
                    real_str(root_distance) // ")"
            else
                message = message // ", and two steps of h/2 fail"
            end if
            if (have_second) then
                message = message // "; the root from the constant first guess changes " // &
                    "the energy by " // real_str(second%pending%energy_change)
                if (half_ok) message = message // " and lies " // real_str(distance(2)) // &
                    " from them"
            end if
            call set_status(status, HOLOSYM_STEP_TOO_LARGE, message // "; reduce h")
            ! The last accepted step stays the last step (its data were not touched).
            self%have_last = had_last
        end select
    end subroutine verify_root

    !> "step with (M, N, G) = (2, 1, 3), h = 1.25000E-0001", for messages, blank-padded:
    !! call sites trim it (a fixed length, not a deferred one: see `int_str`).
    function step_label(self, h) result(text)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: h
        character(len=80) :: text
        text = "step with (M, N, G) = (" // int_str(self%scheme%order_m) // ", " // &
            int_str(self%scheme%order_n) // ", " // int_str(self%scheme%gauss_points) // &
            "), h = " // real_str(h)
    end function step_label


    !> Set the solved step of the last attempt aside.
    subroutine take_candidate(self, candidate)
        class(constrained_integrator), intent(in) :: self
        type(step_candidate_t), intent(out) :: candidate
        candidate%pending = self%pending
        if (self%pending%general) then
            candidate%x = self%x_work
        else
            candidate%x = self%reduced%x
        end if
        candidate%dq = self%dq_work
        candidate%dp = self%dp_work
    end subroutine take_candidate

    !> Make a candidate the solved step again (to be committed with `rebind`).
    subroutine restore_candidate(self, candidate)
        class(constrained_integrator), intent(inout) :: self
        type(step_candidate_t), intent(in) :: candidate
        self%pending = candidate%pending
        if (candidate%pending%general) then
            self%x_work = candidate%x
        else
            self%reduced%x = candidate%x
        end if
        self%dq_work = candidate%dq
        self%dp_work = candidate%dp
    end subroutine restore_candidate

    !> Say why a step failed, where the solver's code alone would mislead:
    !! HOLOSYM_NONFINITE_VALUE naming the Hamiltonian when H of the start state is not
    !! finite (it overflows);
    !! HOLOSYM_STEP_TOO_SMALL when h is below the resolution of the state
    !! (`resolution_limit`); HOLOSYM_RANK_DEFICIENT_CONSTRAINTS when a singular Newton
    !! matrix comes from constraints dependent at the start or at a node of the iterate;
    !! HOLOSYM_STEP_TOO_LARGE when the equations at the constant guess overflow at h, or
    !! (singular matrix) are far better conditioned at h/16 (`probe_step`). A singular
    !! matrix with none of these causes keeps its code with the hint about N and G.
    subroutine diagnose_failure(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(inout) :: status
        character(len=:), allocatable :: message
        real(wp) :: limit, ratio, smaller_ratio, probe_h, lower, upper
        integer :: code, k

        select case (status%code)
        case (HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
              HOLOSYM_NONFINITE_VALUE)
        case default
            return
        end select
        if (.not. is_finite(sys%hamiltonian(q, p))) then
            ! A state beyond the range of the system's numbers (e.g. momenta whose energy
            ! overflows): no step size helps.
            status%code = HOLOSYM_NONFINITE_VALUE
            status%message = trim(step_label(self, h)) // ": hamiltonian returned NaN or " // &
                "Inf at the start state (" // status%message // ")"
            return
        end if
        if (status%code == HOLOSYM_NONFINITE_VALUE) return
        limit = resolution_limit(self, sys, q, p)
        if (h < limit) then
            status%code = HOLOSYM_STEP_TOO_SMALL
            status%message = trim(step_label(self, h)) // ": h is below the resolution " // &
                "of this state: under about h = " // real_str(limit) // " the round-off of q " // &
                "(epsilon |q|) divided by h exceeds Newton's stagnation level in the " // &
                "momenta, so the step's equations cannot be solved; use h >= " // &
                real_str(limit) // " (" // status%message // ")"
            return
        end if
        if (status%code == HOLOSYM_SINGULAR_MATRIX) then
            if (.not. rank_test(self, sys, q, message, dependence_threshold)) then
                status%code = HOLOSYM_RANK_DEFICIENT_CONSTRAINTS
                status%message = trim(step_label(self, h)) // ": at the start of the step " // &
                    message
                return
            else if (len(self%dependent_nodes) > 0) then
                status%code = HOLOSYM_RANK_DEFICIENT_CONSTRAINTS
                status%message = trim(step_label(self, h)) // ": within the step (" // &
                    self%dependent_nodes // "); the constraints become dependent"
                return
            end if
        end if
        ! Too large: the step's equations at the constant guess overflow; or, for a
        ! singular matrix, they are far worse conditioned at h (or the largest step below
        ! it where they are regular) than at a sixteenth of it: the pivot ratio at the
        ! constant guess falls like 1/h beyond the system's time scale, and rises with h
        ! below it.
        code = probe_step(self, sys, q, p, h, ratio)
        if (code == HOLOSYM_NEWTON_DIVERGED) then
            status%code = HOLOSYM_STEP_TOO_LARGE
            status%message = trim(step_label(self, h)) // ": the step is too large: its " // &
                "equations overflow working precision at the first guess; reduce h (" // &
                status%message // ")"
            return
        end if
        if (status%code == HOLOSYM_SINGULAR_MATRIX) then
            ! A step size below h with a regular matrix at the guess: bisection in log h
            ! between h and the resolution limit (beyond the system's time scale the
            ! matrix is singular above some step size, regular below it).
            probe_h = h
            lower = max(limit, sqrt(tiny(1.0_wp)))
            upper = h
            do k = 1, 64
                if (ratio > 0 .or. upper <= 16 * lower) exit
                probe_h = sqrt(lower) * sqrt(upper)
                code = probe_step(self, sys, q, p, probe_h, ratio)
                if (ratio <= 0) upper = probe_h
            end do
            if (ratio > 0) then
                code = probe_step(self, sys, q, p, probe_h / 16, smaller_ratio)
                if (code /= HOLOSYM_NEWTON_DIVERGED .and. smaller_ratio > 0 .and. &
                    smaller_ratio >= large_step_gain * ratio) then
                    status%code = HOLOSYM_STEP_TOO_LARGE
                    status%message = trim(step_label(self, h)) // ": the step is too large: " // &
                        "the Newton matrix at the first guess has pivot ratio " // &
                        real_str(ratio) // " at h = " // real_str(probe_h) // " and " // &
                        real_str(smaller_ratio) // " at h/16 (at this h it is singular to " // &
                        "working precision in the solve); reduce h (" // status%message // ")"
                    return
                end if
            end if
        end if
        if (status%code == HOLOSYM_SINGULAR_MATRIX) then
            if (self%scheme%order_m >= self%scheme%order_n + 2) then
                status%message = status%message // "; M >= N + 2 is singular whenever " // &
                    "H is degenerate along the surplus displacement modes (e.g. a " // &
                    "symmetric potential): use N = M - 1"
            else
                status%message = status%message // "; N or G may be too small for M " // &
                    "(N = M - 1 with G >= M works), or the constraints are nearly dependent"
            end if
        end if
    end subroutine diagnose_failure

    !> The smallest step size the state (q, p) resolves: the round-off of q, epsilon |q|,
    !! makes the velocity z/h of a step uncertain by epsilon |q| / h, i.e. the momenta by
    !! that times a mass |p| / |H_p|; Newton accepts corrections at its stagnation level
    !! (relative to the state's size), so below
    !! h = margin epsilon |q| (|p| / |H_p|) / (stagnation_level max(|q|, |p|)) a step may
    !! fail, `resolution_margin` covering the conditioning of the step's equations.
    function resolution_limit(self, sys, q, p) result(limit)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: limit
        call sys%dh_dp(q, p, self%hp_work)
        limit = state_resolution(self, q, p, self%hp_work)
    end function resolution_limit

    !> `resolution_limit` from the velocity field hp = H_p(q, p); 0 when a value is not
    !! finite.
    pure function state_resolution(self, q, p, hp) result(limit)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:), hp(:)
        real(wp) :: limit
        real(wp) :: scale, mass, velocity, level
        limit = 0
        if (.not. (all(is_finite(q)) .and. all(is_finite(p)) .and. all(is_finite(hp)))) return
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (.not. scale > 0) scale = 1
        velocity = maxval(abs(hp))
        mass = 1
        if (velocity > 0 .and. maxval(abs(p)) > 0) mass = maxval(abs(p)) / velocity
        level = max(stagnation_floor(self%newton), self%newton%tolerance)
        limit = resolution_margin * epsilon(1.0_wp) * maxval(abs(q)) * mass / (level * scale)
    end function state_resolution

    !> One Newton iteration of the step of size h from (q, p) at the constant guess, on the
    !! plain path (working-precision LU; real64 factors where only the reduced step exists):
    !! HOLOSYM_NEWTON_DIVERGED when the equations overflow there, HOLOSYM_SINGULAR_MATRIX
    !! when the Newton matrix is singular there, else HOLOSYM_SUCCESS; `pivot_ratio` the
    !! smallest relative pivot of that matrix (0 when singular). Only the schemes' bound
    !! step and the reduced step's kept factors change.
    integer function probe_step(self, sys, q, p, h, pivot_ratio) result(code)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        real(wp), intent(out) :: pivot_ratio
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report
        type(holosym_status_t) :: local
        type(reduced_report_t) :: reduced_report
        real(wp), allocatable :: x(:)
        real(wp) :: scale
        settings = plain_settings(self%newton)
        settings%max_iterations = 1
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (.not. scale > 0) scale = 1
        if (self%general_ready) then
            call apply_options(self, h, local)
            call self%scheme%set_step(sys, q, p, h)
            allocate (x(self%scheme%nx))
            call self%scheme%constant_guess(x)
            ! A workspace of its own: the working-precision LU, no kept factors touched.
            call newton_solve(self%scheme, x, settings, scale, report, local)
            pivot_ratio = report%pivot_ratio
        else
            call self%reduced%solve(sys, q, p, h, self%newton%tolerance, &
                stagnation_floor(self%newton), 1, .false., self%q_end_work, self%p_end_work, &
                reduced_report, local)
            pivot_ratio = reduced_report%pivot_ratio
        end if
        select case (local%code)
        case (HOLOSYM_NEWTON_DIVERGED, HOLOSYM_SINGULAR_MATRIX)
            code = local%code
        case default
            code = HOLOSYM_SUCCESS
        end select
        if (code == HOLOSYM_SINGULAR_MATRIX .or. .not. is_finite(pivot_ratio)) pivot_ratio = 0
    end function probe_step

    !> Record, after a singular Newton matrix, whether the constraints are dependent at a
    !! displacement node of the iterate where it happened (`dependent_nodes`).
    subroutine record_dependent_nodes(self, sys, q, general)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:)
        logical, intent(in) :: general !! the general scheme's iterate (else the reduced's)
        character(len=:), allocatable :: message
        integer :: i
        if (sys%m == 0 .or. len(self%dependent_nodes) > 0) return
        do i = 1, self%scheme%order_m
            if (general) then
                call self%scheme%node(i, self%q_end_work)
            else
                if (.not. self%reduced%have_singular_x) return
                self%q_end_work = q + &
                    self%reduced%singular_x(self%reduced%scheme%layout%z_col(:, i))
            end if
            if (.not. all(is_finite(self%q_end_work))) cycle
            if (.not. rank_test(self, sys, self%q_end_work, message, &
                                 dependence_threshold)) then
                self%dependent_nodes = "at displacement node " // int_str(i) // " of " // &
                    int_str(self%scheme%order_m) // " of the Newton iterate, " // message
                return
            end if
        end do
    end subroutine record_dependent_nodes

    !> Solve the step by the general scheme (all unknowns, dense Newton), without accepting
    !! it: the solution in x_work, the increments in dq_work, dp_work, its numbers in
    !! `pending`. `extrapolation` allows the previous step's polynomials as first guess.
    subroutine solve_general(self, sys, q, p, h, extrapolation, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: extrapolation
        type(holosym_status_t), intent(out) :: status
        real(wp) :: scale, end_velocity_residual
        type(newton_report_t) :: report
        logical :: extrapolated, from_extrapolation
        integer :: iterations, factorizations
        integer(int64) :: residuals0, gradients0, hessians0, lowered0

        status%code = HOLOSYM_SUCCESS
        residuals0 = self%scheme%counters%residuals
        gradients0 = self%scheme%counters%gradients
        hessians0 = self%scheme%counters%hessians
        lowered0 = self%scheme%counters%lowered_residuals
        call self%scheme%set_step(sys, q, p, h)
        extrapolated = .false.
        if (self%extrapolate .and. extrapolation) extrapolated = &
            continues_last_step(self, q, p) .and. self%last_general
        call first_guess()
        ! Increments are compared with the size of the state, not with themselves.
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (scale <= 0) scale = 1
        iterations = 0
        factorizations = 0
        end_velocity_residual = 0
        call solve_with_retries(self%newton)
        if (.not. status%ok() .and. status%code /= HOLOSYM_NONFINITE_VALUE .and. &
            fast_options(self)) then
            ! The speed options are heuristics: before failing the step, the plain path
            ! (full Newton, working-precision LU, no pre-solve) gets its chance.
            call self%workspace%invalidate()
            self%workspace%linear_solver = LINEAR_SOLVER_NATIVE
            call first_guess()
            call solve_with_retries(plain_settings(self%newton))
            call self%workspace%invalidate()
            ! The next steps use the chosen linear solver again.
            self%workspace%linear_solver = self%applied_modes(1)
        end if
        self%stats%newton_iterations = self%stats%newton_iterations + iterations
        self%stats%lu_factorizations = self%stats%lu_factorizations + factorizations
        self%stats%jacobian_evaluations = self%stats%jacobian_evaluations + factorizations
        call count_evaluations()
        if (.not. status%ok()) then
            status%message = trim(step_label(self, h)) // ": " // status%message
            return
        end if
        self%pending%general = .true.
        self%pending%extrapolated = from_extrapolation
        self%pending%iterations = iterations
        self%pending%factorizations = factorizations
        self%pending%pivot_ratio = report%pivot_ratio
        ! Hidden constraint at the step end, max |Phi(q_b) H_p(q_b, p_b)| (check_end_state).
        self%pending%velocity = end_velocity_residual

    contains

        !> Newton from x_work with `settings`; on failure retry with fresh factors (kept
        !! ones may be stale) and from the constant guess (a poor extrapolation should
        !! not fail the step). On success the step's increments are in dq_work, dp_work
        !! and the end state is checked against the constraints.
        subroutine solve_with_retries(settings)
            type(newton_settings_t), intent(in) :: settings
            call attempt(settings)
            if (.not. status%ok() .and. report%reused_factors .and. &
                status%code /= HOLOSYM_NONFINITE_VALUE) call attempt(settings)
            if (.not. status%ok() .and. extrapolated .and. &
                status%code /= HOLOSYM_NONFINITE_VALUE) then
                call self%scheme%constant_guess(self%x_work)
                from_extrapolation = .false.
                call attempt(settings)
            end if
            if (.not. status%ok()) return
            call self%scheme%increments(self%x_work, self%dq_work, self%dp_work, status)
            if (.not. status%ok()) return
            if (.not. (all_finite(self%dq_work) .and. all_finite(self%dp_work))) then
                call set_status(status, HOLOSYM_NEWTON_DIVERGED, "step produced a " // &
                    "non-finite state (overflow)")
                return
            end if
            call check_end_state(status)
        end subroutine solve_with_retries

        !> x_work = the previous step's polynomials extrapolated, or the constant guess.
        subroutine first_guess()
            from_extrapolation = extrapolated
            if (extrapolated) then
                call self%scheme%extrapolated_guess(self%last_x, self%last_qa, self%last_pa, &
                                                    self%last_h, q, p, h, self%x_work)
            else
                call self%scheme%constant_guess(self%x_work)
            end if
        end subroutine first_guess

        !> One Newton solve from x_work, its work added to the step's.
        subroutine attempt(settings)
            type(newton_settings_t), intent(in) :: settings
            call newton_solve(self%scheme, self%x_work, settings, scale, report, status, &
                              self%workspace)
            iterations = iterations + report%iterations
            factorizations = factorizations + report%factorizations
            if (status%code == HOLOSYM_SINGULAR_MATRIX) &
                call record_dependent_nodes(self, sys, q, .true.)
        end subroutine attempt

        !> A Newton iteration that stopped far from a solution (e.g. at an absurd h, where
        !! the relative test is met by huge iterates) leaves the end state off the
        !! constraint manifold: fail the solve when a scaled residual exceeds
        !! `end_state_tolerance` (loose: nearly dependent constraints legitimately end
        !! steps some orders above epsilon).
        subroutine check_end_state(status)
            type(holosym_status_t), intent(inout) :: status
            real(wp) :: position, velocity, scaled_position, scaled_velocity
            self%q_end_work = q + self%dq_work
            self%p_end_work = p + self%dp_work
            call manifold_residuals(sys, self%q_end_work, self%p_end_work, position, &
                                    velocity, scaled_position, scaled_velocity, self%hp_work)
            self%scheme%counters%gradients = self%scheme%counters%gradients + 1
            end_velocity_residual = velocity
            call end_state_status(position, velocity, scaled_position, scaled_velocity, &
                                  end_tolerance(self), status)
        end subroutine check_end_state

        !> Evaluations of this attempt from the scheme's counters.
        subroutine count_evaluations()
            integer(int64) :: residuals, gradients, hessians, lowered
            residuals = self%scheme%counters%residuals - residuals0
            gradients = self%scheme%counters%gradients - gradients0
            hessians = self%scheme%counters%hessians - hessians0
            lowered = self%scheme%counters%lowered_residuals - lowered0
            self%pending%lowered = int(lowered)
            self%stats%lowered_residual_evaluations = self%stats%lowered_residual_evaluations &
                + lowered
            self%pending%residuals = int(residuals)
            self%pending%gradients = int(gradients)
            self%pending%hessians = int(hessians)
            self%stats%residual_evaluations = self%stats%residual_evaluations + residuals
            self%stats%gradient_evaluations = self%stats%gradient_evaluations + gradients
            self%stats%hessian_evaluations = self%stats%hessian_evaluations + hessians
        end subroutine count_evaluations

    end subroutine solve_general

    !> The end-state test of a solved step: non-finite residuals (from the system's
    !! constraint or dh_dp at the end state) fail with HOLOSYM_NONFINITE_VALUE, scaled
    !! residuals above `end_state_tolerance` with HOLOSYM_NEWTON_NOT_CONVERGED.
    subroutine end_state_status(position, velocity, scaled_position, scaled_velocity, &
                                tolerance, status)
        real(wp), intent(in) :: position, velocity, scaled_position, scaled_velocity
        real(wp), intent(in) :: tolerance !! largest accepted scaled residual
        type(holosym_status_t), intent(inout) :: status
        if (.not. (is_finite(scaled_position) .and. is_finite(scaled_velocity))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint, " // &
                "constraint_jacobian or dh_dp returned NaN or Inf at the end state")
        else if (scaled_position > tolerance .or. scaled_velocity > tolerance) then
            call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "Newton stopped at a " // &
                "point off the constraints (end state max|phi| = " // real_str(position) // &
                ", max|Phi H_p| = " // real_str(velocity) // ")")
        end if
    end subroutine end_state_status

    !> Solve the step by the reduced step (momenta eliminated; `holosym_reduced_step`),
    !! without accepting it: the solution in reduced%x, the increments in dq_work, dp_work,
    !! its numbers in `pending`.
    subroutine solve_reduced(self, sys, q, p, h, extrapolation, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: extrapolation
        type(holosym_status_t), intent(out) :: status
        type(reduced_report_t) :: report
        real(wp) :: position, velocity, scaled_position, scaled_velocity
        integer :: gradients0

        gradients0 = self%reduced%scheme%gradients
        call self%reduced%solve(sys, q, p, h, self%newton%tolerance, &
            stagnation_floor(self%newton), self%newton%max_iterations, &
            self%extrapolate .and. extrapolation .and. continues_last_step(self, q, p), &
            self%dq_work, self%dp_work, report, status)
        self%stats%newton_iterations = self%stats%newton_iterations + report%iterations
        self%stats%lu_factorizations = self%stats%lu_factorizations + report%factorizations
        self%stats%jacobian_evaluations = self%stats%jacobian_evaluations + report%factorizations
        self%stats%residual_evaluations = self%stats%residual_evaluations + report%residuals
        self%stats%lowered_residual_evaluations = self%stats%lowered_residual_evaluations + &
            report%lowered_residuals
        self%stats%gradient_evaluations = self%stats%gradient_evaluations + &
            (self%reduced%scheme%gradients - gradients0)
        if (status%ok()) then
            if (.not. (all_finite(self%dq_work) .and. all_finite(self%dp_work))) &
                call set_status(status, HOLOSYM_NEWTON_DIVERGED, "step produced a " // &
                "non-finite state (overflow)")
        end if
        if (status%ok()) then
            self%q_end_work = q + self%dq_work
            self%p_end_work = p + self%dp_work
            call state_residuals(self, sys, self%q_end_work, self%p_end_work, position, &
                                 velocity, scaled_position, scaled_velocity, self%hp_work)
            if (sys%m == 0) self%stats%gradient_evaluations = &
                self%stats%gradient_evaluations + 1
            call end_state_status(position, velocity, scaled_position, scaled_velocity, &
                                  end_tolerance(self), status)
        end if
        if (.not. status%ok()) then
            if (status%code == HOLOSYM_SINGULAR_MATRIX) &
                call record_dependent_nodes(self, sys, q, .false.)
            status%message = "reduced " // trim(step_label(self, h)) // ": " // status%message
            self%have_last = .false.
            return
        end if
        self%pending%general = .false.
        self%pending%extrapolated = self%reduced%extrapolated
        self%pending%iterations = report%iterations
        self%pending%pivot_ratio = report%pivot_ratio
        self%pending%factorizations = report%factorizations
        self%pending%residuals = report%residuals
        self%pending%lowered = report%lowered_residuals
        self%pending%gradients = self%reduced%scheme%gradients - gradients0
        self%pending%hessians = 0
        self%pending%velocity = velocity
    end subroutine solve_reduced

    !> Advance (q, p) by one step of size h. On failure q and p are unchanged.
    !! Codes: HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH,
    !! HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_ARGUMENT (also a setting out of range),
    !! HOLOSYM_OFF_MANIFOLD, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, HOLOSYM_SINGULAR_MATRIX,
    !! HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NONFINITE_VALUE
    !! (a procedure of the system returned NaN or Inf), HOLOSYM_STEP_TOO_LARGE,
    !! HOLOSYM_STEP_TOO_SMALL (see docs/status-codes.md).
    subroutine integrator_step(self, sys, q, p, h, info, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(inout) :: q(:) !! coordinates (n): q_a in, q_b out
        real(wp), intent(inout) :: p(:) !! momenta (n): p_a in, p_b out
        real(wp), intent(in) :: h       !! step size > 0
        type(step_info_t), intent(out), optional :: info !! diagnostics of the step
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local

        call validate(self, sys, q, p, h, local)
        if (local%ok()) call apply_options(self, h, local)
        if (local%ok()) call solve_step(self, sys, q, p, h, local)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        q = self%last_qb
        p = self%last_pb
        if (present(info)) info = self%last_info
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine integrator_step

    !> Advance (q, p) by `steps` steps of size h, calling `observer` after each.
    !! Increments are accumulated with compensated summation. On failure (or when the
    !! observer halts, code HOLOSYM_USER_ABORT) q and p hold the last good step's state and
    !! `steps_done` says how many steps completed. Codes: those of `step`, and
    !! HOLOSYM_INVALID_STEP_COUNT for steps < 0, HOLOSYM_USER_ABORT.
    subroutine integrator_integrate(self, sys, q, p, h, steps, observer, steps_done, status, &
                                    start_time)
        class(constrained_integrator), intent(inout), target :: self
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(inout) :: q(:) !! coordinates (n): start in, end out
        real(wp), intent(inout) :: p(:) !! momenta (n): start in, end out
        real(wp), intent(in) :: h       !! step size > 0
        integer, intent(in) :: steps    !! number of steps >= 0
        class(step_observer), intent(inout), optional :: observer !! receives every step
        integer, intent(out), optional :: steps_done !! steps completed
        type(holosym_status_t), intent(out), optional :: status !! outcome
        real(wp), intent(in), optional :: start_time !! t of the start state (default 0)
        type(holosym_status_t) :: local
        real(wp), allocatable :: q_error(:), p_error(:), summand(:), total(:)
        real(wp) :: t0
        integer :: k
        logical :: halt

        if (present(steps_done)) steps_done = 0
        if (steps < 0) then
            call set_status(status, HOLOSYM_INVALID_STEP_COUNT, "step count must be >= 0; got " &
                // int_str(steps))
            return
        end if
        call validate(self, sys, q, p, h, local)
        ! Options are translated once per call, not in the loop of steps.
        if (local%ok()) call apply_options(self, h, local)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        ! A run that does not continue the last step depends only on its arguments: the
        ! factors and habits simplified Newton learnt in earlier runs are forgotten.
        if (.not. continues_last_step(self, q, p)) then
            call self%workspace%reset()
            if (self%reduced_active) call self%reduced%forget()
        end if
        t0 = 0
        if (present(start_time)) t0 = start_time
        allocate (q_error(size(q)), p_error(size(p)), summand(size(q)), total(size(q)))
        q_error = 0
        p_error = 0
        halt = .false.
        do k = 1, steps
            call solve_step(self, sys, q, p, h, local)
            if (.not. local%ok()) then
                call set_status(status, local%code, "after " // int_str(k - 1) // " steps: " // &
                    local%message)
                return
            end if
            ! Kahan summation: carry the low-order part of each update into the next.
            summand = self%dq_work + q_error
            total = q + summand
            q_error = (q - total) + summand
            q = total
            summand = self%dp_work + p_error
            total = p + summand
            p_error = (p - total) + summand
            p = total
            ! The next step continues from exactly this state.
            self%last_qb = q
            self%last_pb = p
            if (present(steps_done)) steps_done = k
            if (present(observer)) then
                observer%dense%t_start = t0 + (k - 1) * h
                observer%dense%t_end = t0 + k * h
                observer%dense%integrator => self
                call observer%observe(k, t0 + k * h, q, p, self%last_info, halt)
                observer%dense = step_dense_output()
                if (halt .and. k < steps) then
                    call set_status(status, HOLOSYM_USER_ABORT, "observer stopped the run after " &
                        // int_str(k) // " of " // int_str(steps) // " steps")
                    return
                end if
            end if
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine integrator_integrate

    !> Dense output of the last successful step: q~(tau), p~(tau), lambda~(tau), tau in [0, 1].
    !! Codes: HOLOSYM_NOT_INITIALIZED (no step yet), HOLOSYM_INVALID_ARGUMENT (tau outside
    !! [0, 1]), HOLOSYM_SIZE_MISMATCH.
    subroutine integrator_dense_output(self, tau, q, p, lambda, status)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: tau          !! normalised time within the last step
        real(wp), intent(out) :: q(:)        !! q~(tau), size n
        real(wp), intent(out) :: p(:)        !! p~(tau), size n
        real(wp), intent(out) :: lambda(:)   !! lambda~(tau), size m
        type(holosym_status_t), intent(out), optional :: status !! outcome
        if (.not. self%have_last) then
            call set_status(status, HOLOSYM_NOT_INITIALIZED, "dense output needs a completed step")
        else if (.not. is_finite(tau)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tau must be in [0, 1]; got " // &
                real_str(tau))
        else if (tau < 0 .or. tau > 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tau must be in [0, 1]; got " // &
                real_str(tau))
        else if (size(q) /= self%scheme%n .or. size(p) /= self%scheme%n .or. &
                 size(lambda) /= self%scheme%m) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "dense output needs q, p of size " // &
                int_str(self%scheme%n) // " and lambda of size " // int_str(self%scheme%m))
        else
            if (.not. self%last_general) then
                call self%reduced%scheme%dense(self%reduced%last_x, self%last_qa, self%last_h, &
                                               tau, q, p, lambda)
            else
                call self%scheme%dense(self%last_x, self%last_qa, self%last_pa, self%last_h, &
                                       tau, q, p, lambda)
            end if
            call set_status(status, HOLOSYM_SUCCESS, "")
        end if
    end subroutine integrator_dense_output

    !> q~(t), p~(t), lambda~(t) of the step just taken, t in [t_start, t_end] (the step's
    !! polynomials at tau = (t - t_start)/(t_end - t_start)). Codes: HOLOSYM_NOT_INITIALIZED
    !! (called outside `observe` of `integrate`), HOLOSYM_INVALID_ARGUMENT (t outside the
    !! step or not finite), HOLOSYM_SIZE_MISMATCH (q, p not of size n or lambda not of
    !! size m). On failure q, p and lambda are unchanged.
    subroutine dense_evaluate(self, t, q, p, lambda, status)
        class(step_dense_output), intent(in) :: self
        real(wp), intent(in) :: t            !! time in [t_start, t_end]
        real(wp), intent(inout) :: q(:)      !! q~(t), size n
        real(wp), intent(inout) :: p(:)      !! p~(t), size n
        real(wp), intent(inout) :: lambda(:) !! lambda~(t), size m
        type(holosym_status_t), intent(out), optional :: status !! outcome
        real(wp) :: tau
        real(wp), allocatable :: qw(:), pw(:), lw(:)
        type(holosym_status_t) :: local
        if (.not. associated(self%integrator)) then
            call set_status(status, HOLOSYM_NOT_INITIALIZED, "the dense output of a step " // &
                "is available only inside observe, during integrate")
            return
        end if
        if (.not. (is_finite(t) .and. t >= min(self%t_start, self%t_end) .and. &
                   t <= max(self%t_start, self%t_end))) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "t must be in the step [" // &
                real_str(self%t_start) // ", " // real_str(self%t_end) // "]; got " // &
                real_str(t))
            return
        end if
        tau = (t - self%t_start) / (self%t_end - self%t_start)
        tau = min(1.0_wp, max(0.0_wp, tau))
        allocate (qw(size(q)), pw(size(p)), lw(size(lambda)))
        call self%integrator%dense_output(tau, qw, pw, lw, local)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        q = qw
        p = pw
        lambda = lw
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine dense_evaluate

    !> True inside `observe` of `integrate`, when `evaluate` refers to the step just taken.
    pure logical function dense_available(self)
        class(step_dense_output), intent(in) :: self
        dense_available = associated(self%integrator)
    end function dense_available

    !> Diagnostics of the last successful step.
    function integrator_last_step(self) result(info)
        class(constrained_integrator), intent(in) :: self
        type(step_info_t) :: info
        info = self%last_info
    end function integrator_last_step

end module holosym_integrator
