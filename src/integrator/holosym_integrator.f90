!> category: internal module (use holosym)
!! The integrator: set up with (M, N, G), advance a state by one step or many.
!!
!! `step` advances (q, p) by h in place and leaves them unchanged on failure.
!! `integrate` runs many steps with compensated summation of the increments (round-off
!! grows like the square root of the step count), reports each step to an optional
!! observer, and on failure keeps the state of the last good step.
!!
!! Two paths. Where a system declares a constant diagonal mass matrix (`diagonal_mass`,
!! every built-in model and model file does) the default, `structured = .true.`, takes the
!! reduced step (momenta eliminated, sparse or banded real64 factors of its Newton matrix,
!! simplified Newton with a real64 first phase); `structured = .false.` before `init`
!! takes the general step (all unknowns, dense Newton matrix). Both iterate the same
!! working-precision equations to the same tolerance, so the results agree to round-off.
!!
!! Speed options (components of the integrator). Defaults first; the second value gives
!! the plain path (full Newton, working-precision LU), which is also tried automatically
!! when a fast solve fails. The general step honours every value; the reduced step
!! honours the defaults only, and refuses the other values at the first step
!! (HOLOSYM_INVALID_ARGUMENT naming the option) rather than ignore them:
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
!! - `hessians` (`'automatic'` | `'user'` | `'differences'`): the path's own choice, the
!!   system's `hessian` bindings, or differences of its gradients. `'automatic'` is
!!   `'user'` on the general step; the reduced step uses the bindings when no sparsity is
!!   declared (or the system is small) and differences along the colours of the coupling
!!   graph otherwise, and refuses the other explicit value.
!! - `extrapolate` (`.true.` | `.false.`): first guess from the previous step's polynomials
!!   (both paths).
!! - `iteration` (`'automatic'` | `'newton'`): the reduced step iterates without the
!!   Newton matrix where that contracts well (see the component), or always with it;
!!   the general step always uses the Newton matrix (both values are honoured).
!!
!! The other Newton settings (`tolerance`, `stagnation_level`, `max_iterations`,
!! `max_growth`, `pivot_tolerance`, `contraction_limit`, `jacobian_cost`) act on both
!! paths; `contraction_limit` 0 and a negative `jacobian_cost` (the defaults) mean each
!! path's own value.
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
!!
!! This file holds the types and the procedures they bind; the rest of the module is in
!! its submodules, in src/integrator: `holosym_integrator_state.f90` (the checks of a start
!! state before a step, the residual and rank tests through the path's sparsity),
!! `holosym_integrator_settings.f90` (the ranges of the settings, their translation into
!! the modes of the scheme and of Newton's workspace), `holosym_integrator_solve.f90` (one
!! step: its Newton solve by the general or the reduced scheme, with retries and end-state
!! checks, and its acceptance), `holosym_integrator_roots.f90` (the check of a suspicious
!! root against two steps of h/2), `holosym_integrator_diagnosis.f90` (the cause of a
!! failed step, the resolution limit of a state) and `holosym_integrator_tangent.f90`
!! (`step_tangent`: the derivative of the step map).
module holosym_integrator
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_STEP_COUNT, &
        HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_newton, only: newton_settings_t, newton_workspace_t
    use holosym_scheme, only: discrete_scheme
    use holosym_manifold, only: manifold_tolerance_default
    use holosym_reduced_step, only: reduced_step_t
    use holosym_reduced_scheme, only: reduced_structure
    implicit none
    private

    public :: constrained_integrator, step_info_t, step_observer, integrator_stats_t, &
        step_dense_output

    !> Default `linear_solver`: real64 LAPACK factors of a real64 Jacobian, refined with the
    !! working-precision residual ('lapack' names the same in the real64 build).
    character(len=*), parameter :: default_linear_solver = &
        trim(merge("lapack", "mixed ", wp_is_double))

    !> The reduced step falls back on the general one for systems with at most this many
    !! general unknowns (its dense workspace is then at most a few megabytes).
    integer, parameter :: general_fallback_size = 400

    !> What one step did and how well the constraints hold after it.
    type :: step_info_t
        !> Newton iterations of the step.
        integer :: newton_iterations = 0
        !> max |phi| over the step's displacement nodes q_0..q_M.
        real(wp) :: constraint_residual = 0
        !> max |phi(q_b)| at the step end (`project_end_state` keeps it at round-off when
        !! the Newton tolerance is loose; the nodes inside the step keep the Newton error).
        real(wp) :: end_constraint_residual = 0
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
        !> Newton iterations with the iteration matrix without curvature instead of the
        !! Newton matrix (`iteration = 'automatic'` on the reduced step).
        integer(int64) :: approximate_iterations = 0
        !> Working-precision residuals whose inner sums were in double-double arithmetic
        !! (`residual_sums = 'double-double'`).
        integer(int64) :: paired_residual_evaluations = 0
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

    !> The two steps: the general scheme (all unknowns, dense Newton matrix) and the
    !! reduced step (momenta eliminated, sparse or banded real64 factors).
    integer, parameter :: STEP_GENERAL = 1, STEP_REDUCED = 2

    !> The integrator's path: the one record of which step a system takes, which it may
    !! fall back on and which solved the last accepted step. The procedures that differ
    !! between the two steps (solution nodes, momentum jump, dense output, multipliers,
    !! acceptance) dispatch on it in holosym_integrator_paths.f90.
    type :: path_t
        !> The step of this system: STEP_REDUCED where it declares a constant diagonal mass
        !! matrix and `structured` was set at `init`, else STEP_GENERAL.
        integer :: main = STEP_GENERAL
        !> The general scheme is set up: the main step, or the reduced step's fallback for
        !! small systems.
        logical :: general_ready = .false.
        !> The step that solved the last accepted step (its dense output, extrapolation).
        integer :: last = STEP_GENERAL
    end type path_t

    !> The numbers of a solved step that is not accepted yet (see `commit_step`).
    type :: pending_t
        integer :: step = STEP_GENERAL    ! the step that solved it (STEP_GENERAL, _REDUCED)
        logical :: extrapolated = .false. ! from the extrapolated first guess
        integer :: iterations = 0, factorizations = 0, residuals = 0, lowered = 0
        integer :: gradients = 0, hessians = 0
        real(wp) :: pivot_ratio = 0
        real(wp) :: velocity = 0          ! max |Phi H_p| at the end state
        real(wp) :: position = 0          ! max |phi| over the displacement nodes
        real(wp) :: end_position = 0      ! max |phi| at the end state
        real(wp) :: energy = 0            ! H at the end state (when `energy_known`)
        logical :: energy_known = .false.
        logical :: energy_finite = .true. ! H finite at both ends (see `energy_change`)
        real(wp) :: energy_change = 0     ! see `energy_change`
        real(wp) :: momentum_jump = 0     ! see `momentum_jump`
    end type pending_t

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
        !> Second derivatives: 'automatic' (the path's own choice: the system's bindings on
        !! the general step), 'user' (the system's bindings) or 'differences' (of gradients).
        character(len=16) :: hessians = "automatic"
        !> The iteration of the step's equations: 'automatic' (the reduced step iterates
        !! with a matrix without the second derivatives, its constraint forces from a small
        !! solve in the multipliers, wherever that contracts by 0.1 per iteration, and with
        !! the Newton matrix elsewhere; the general step always with the Newton matrix) or
        !! 'newton' (the Newton matrix throughout).
        character(len=16) :: iteration = "automatic"
        !> The inner sums of the reduced step's working-precision residual (its Gauss
        !! positions and node sums, most of its real128 arithmetic): 'double-double' (pairs
        !! of real64 numbers, 106 bits: real128 build only, with `newton%tolerance` at
        !! least `double_double_floor` = 2^-100, above the sums' rounding of about 2^-104
        !! of their terms), 'working' (working precision), or 'automatic': double-double
        !! wherever it may be used (real128, that tolerance), else working precision. The
        !! general step, also as the reduced step's fallback, sums in working precision.
        character(len=16) :: residual_sums = "automatic"
        !> Step results from the last iterate's evaluation updated to first order (saves an
        !! evaluation per step) instead of a new evaluation at the solution.
        logical :: linear_increments = .true.
        !> After a failed reduced step (not a fault of the system), solve it again with the
        !! general step, whose Newton matrix is factored in working precision (systems of up
        !! to 400 unknowns in the general step): nearly dependent constraints, real64 steps
        !! at round-off. `.false.` lets such a step fail at once (as the pilot of
        !! `init_for_accuracy` does while it searches for a step the motion allows).
        logical :: general_fallback = .true.
        !> Where `newton%tolerance` is looser than the default (`default_newton_tolerance`;
        !! `init_for_accuracy` derives such tolerances from a request), project the end
        !! state of every step onto the constraints: q along the constraint normals, then
        !! p (banded, through Phi's pattern, on the reduced step), so that phi and Phi H_p
        !! hold to round-off at every step's end at any tolerance. The correction is of
        !! the size of the Newton error; the displacement nodes inside the step keep
        !! theirs. `.false.` keeps the iteration's end state.
        logical :: project_end_state = .true.
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
        ! Which step this system takes, which it falls back on, which solved the last step.
        type(path_t), private :: path
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
        ! The general scheme of `step_tangent`, set up at its first call after `init`.
        type(discrete_scheme), private :: tangent_scheme
        logical, private :: tangent_ready = .false.
    contains
        !> Set up for a system and (M, N, G).
        procedure :: init => integrator_init
        !> One step of size h, in place.
        procedure :: step => integrator_step
        !> Many steps of size h, in place, with an optional observer.
        procedure :: integrate => integrator_integrate
        !> One step, and the step map's derivative applied to tangent vectors, in place.
        procedure :: step_tangent => integrator_step_tangent
        !> q~, p~, lambda~ of the last step at tau in [0, 1].
        procedure :: dense_output => integrator_dense_output
        !> Diagnostics of the last successful step.
        procedure :: last_step => integrator_last_step
        !> (M, N, G) of the scheme.
        procedure :: orders => integrator_orders
        !> Zero the work counters `stats`.
        procedure :: reset_statistics => integrator_reset_statistics
    end type constrained_integrator

    ! The procedures of the submodules that other files of the module call (private). Every
    ! procedure a submodule calls is defined in a submodule: gfortran gives the private
    ! procedures of a module internal linkage, out of reach of its submodules.
    interface
        ! Checks of a state: holosym_integrator_state.f90.

        !> Check everything a step needs before touching the state.
        module subroutine validate(self, sys, q, p, h, status)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in) :: sys !! the system
            real(wp), intent(in) :: q(:), p(:), h !! start state and step size
            type(holosym_status_t), intent(out) :: status !! the first failed check, or success
        end subroutine validate
        !> True when (q, p) is exactly the end state of the last successful step.
        pure module logical function continues_last_step(self, q, p)
            class(constrained_integrator), intent(in) :: self !! the integrator
            real(wp), intent(in) :: q(:), p(:) !! a state
        end function continues_last_step
        !> `manifold_residuals`, through Phi's sparse pattern on the reduced path.
        module subroutine state_residuals(self, sys, q, p, position, velocity, scaled_position, &
                                          scaled_velocity, velocity_field)
            class(constrained_integrator), intent(in) :: self !! the integrator
            class(constrained_hamiltonian), intent(in) :: sys !! the system
            real(wp), intent(in) :: q(:), p(:) !! the state
            !> max |phi|, max |Phi H_p| and both scaled as in `manifold_residuals`
            real(wp), intent(out) :: position, velocity, scaled_position, scaled_velocity
            real(wp), intent(out), optional :: velocity_field(:) !! H_p(q, p)
        end subroutine state_residuals
        !> `full_rank_constraints`, banded through Phi's sparse pattern on the reduced path.
        module logical function rank_test(self, sys, q, message, threshold, finite)
            class(constrained_integrator), intent(in) :: self !! the integrator
            class(constrained_hamiltonian), intent(in) :: sys !! the system
            real(wp), intent(in) :: q(:) !! coordinates
            character(len=:), allocatable, intent(out) :: message !! why the rank is deficient
            real(wp), intent(in), optional :: threshold !! relative pivot of Phi Phi^T
            logical, intent(out), optional :: finite    !! false: Phi not finite (result true)
        end function rank_test

        ! Settings: holosym_integrator_settings.f90.

        !> Whether every setting is in its range; `message` names the first that is not.
        module logical function settings_valid(self, message)
            class(constrained_integrator), intent(in) :: self !! the integrator
            character(len=:), allocatable, intent(out) :: message !! "" or the setting at fault
        end function settings_valid
        !> Whether the reduced step sums in double-double arithmetic (`residual_sums`).
        pure module logical function paired_sums(self)
            class(constrained_integrator), intent(in) :: self !! the integrator
        end function paired_sums
        !> Largest scaled constraint residual of an accepted end state.
        pure module real(wp) function end_tolerance(self)
            class(constrained_integrator), intent(in) :: self !! the integrator
        end function end_tolerance
        !> Translate the option strings into the modes of the scheme and the Newton workspace.
        module subroutine apply_options(self, h, status)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            real(wp), intent(in) :: h !! step size the kept factors belong to
            type(holosym_status_t), intent(inout) :: status !! HOLOSYM_INVALID_ARGUMENT or kept
        end subroutine apply_options
        !> True when any of the Newton speed options is in use.
        pure module logical function fast_options(self)
            class(constrained_integrator), intent(in) :: self !! the integrator
        end function fast_options
        !> `settings` with the speed options of Newton's method off.
        pure module function plain_settings(settings) result(plain)
            type(newton_settings_t), intent(in) :: settings !! Newton settings
            type(newton_settings_t) :: plain
        end function plain_settings

        ! Solving and accepting a step: holosym_integrator_solve.f90.

        !> One step from (q, p), which stay unchanged: solve, check the root, accept it.
        module subroutine solve_step(self, sys, q, p, h, status)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(in) :: q(:), p(:), h !! start state and step size
            type(holosym_status_t), intent(out) :: status !! outcome of the step
        end subroutine solve_step
        !> Solve the step from (q, p) without accepting it (into `pending` and the work arrays).
        module logical function refused(self, h, status)
            class(constrained_integrator), intent(in) :: self
            real(wp), intent(in) :: h
            type(holosym_status_t), intent(inout) :: status
        end function refused

        module subroutine attempt_step(self, sys, q, p, h, extrapolation, status)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(in) :: q(:), p(:), h !! start state and step size
            logical, intent(in) :: extrapolation !! the previous step may give the first guess
            type(holosym_status_t), intent(out) :: status !! outcome of the solve
        end subroutine attempt_step
        !> Accept the step solved by the last attempt: it becomes the last step.
        module subroutine commit_step(self, sys, q, p, h, rebind)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(in) :: q(:), p(:), h !! start state and step size
            logical, intent(in) :: rebind !! bind the general scheme to this step again
        end subroutine commit_step
        !> "step with (M, N, G) = (2, 1, 3), h = 1.25000E-0001", for messages, blank-padded.
        module function step_label(self, h) result(text)
            class(constrained_integrator), intent(in) :: self !! the integrator
            real(wp), intent(in) :: h !! step size
            character(len=80) :: text
        end function step_label

        ! Root verification: holosym_integrator_roots.f90.

        !> Whether the solved step may be a spurious Newton root (records its numbers).
        module logical function suspicious(self, sys, q, p, h)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in) :: sys !! the system
            real(wp), intent(in) :: q(:), p(:), h !! start state and step size
        end function suspicious
        !> Accept the root that agrees with two steps of h/2, or fail the step.
        module subroutine verify_root(self, sys, q, p, h, status)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(in) :: q(:), p(:), h !! start state and step size
            type(holosym_status_t), intent(out) :: status !! HOLOSYM_STEP_TOO_LARGE or success
        end subroutine verify_root

        ! Failure diagnosis: holosym_integrator_diagnosis.f90.

        !> Say why a step failed, where the solver's code alone would mislead.
        module subroutine diagnose_failure(self, sys, q, p, h, status)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(in) :: q(:), p(:), h !! start state and step size
            type(holosym_status_t), intent(inout) :: status !! the failure; its code the cause's
        end subroutine diagnose_failure
        !> The smallest step size the state resolves, from hp = H_p(q, p).
        pure module function state_resolution(self, q, p, hp) result(limit)
            class(constrained_integrator), intent(in) :: self !! the integrator
            real(wp), intent(in) :: q(:), p(:), hp(:) !! the state and its velocity field
            real(wp) :: limit
        end function state_resolution
        !> Record whether the constraints are dependent at a node of a singular iterate.
        module subroutine record_dependent_nodes(self, sys, q, general)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in) :: sys !! the system
            real(wp), intent(in) :: q(:) !! start coordinates of the step
            logical, intent(in) :: general !! the general scheme's iterate (else the reduced's)
        end subroutine record_dependent_nodes

        ! What differs between the two steps: holosym_integrator_paths.f90.

        !> Displacement node i (0..M) of the pending step from q.
        module subroutine path_node(self, q, i, node)
            class(constrained_integrator), intent(in) :: self !! the integrator
            real(wp), intent(in) :: q(:) !! start coordinates of the step
            integer, intent(in) :: i !! node index, 0..M
            real(wp), intent(out) :: node(:) !! q at node i
        end subroutine path_node
        !> Momentum polynomial's ends against the pending step's end momenta (absolute).
        module function path_momentum_jump(self, p, h) result(jump)
            class(constrained_integrator), intent(in) :: self !! the integrator
            real(wp), intent(in) :: p(:), h !! start momenta and step size
            real(wp) :: jump
        end function path_momentum_jump
        !> A copy of the pending step's unknowns.
        module subroutine path_solution(self, x)
            class(constrained_integrator), intent(in) :: self !! the integrator
            real(wp), allocatable, intent(out) :: x(:) !! the unknowns
        end subroutine path_solution
        !> Make `x` (from `path_solution`) the pending step's unknowns again.
        module subroutine path_restore_solution(self, x)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            real(wp), intent(in) :: x(:) !! the unknowns
        end subroutine path_restore_solution
        !> Accept the pending step on its path: its polynomials kept, its multipliers.
        module subroutine path_accept(self, sys, q, p, h, rebind)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(in) :: q(:), p(:), h !! start state and step size
            logical, intent(in) :: rebind !! bind the general scheme to this step again
        end subroutine path_accept
        !> Dense output of the last accepted step at tau in [0, 1].
        module subroutine path_dense(self, tau, q, p, lambda)
            class(constrained_integrator), intent(in) :: self !! the integrator
            real(wp), intent(in) :: tau !! fraction of the step
            real(wp), intent(out) :: q(:), p(:), lambda(:) !! q~, p~, lambda~ at tau
        end subroutine path_dense

        ! The tangent map: holosym_integrator_tangent.f90.

        !> One step of size h (as `step`) and the derivative of the step map, restricted to
        !! the constraint manifold, applied to the tangent vectors (dq(:, k), dp(:, k)) at
        !! the start state: on success q, p hold the end state and dq, dp the images of the
        !! vectors there. The derivative comes from the implicit-function theorem on the
        !! general scheme's equations at the step's solution (whichever path solved it):
        !! one solve per vector with the real64 factors of the Newton matrix, refined in
        !! working precision, so it is exact to round-off when the system's second
        !! derivatives are (its `hessian` and `constraint_hessian`; the difference defaults
        !! give about half the digits). It maps the tangent space into the tangent space
        !! and is symplectic there. Codes: those of `step`; HOLOSYM_SIZE_MISMATCH (dq, dp
        !! not n x k alike), HOLOSYM_INVALID_ARGUMENT (a non-finite entry),
        !! HOLOSYM_OFF_MANIFOLD (a vector with `tangent_residual` above
        !! `tangent_tolerance`: `project_tangent` projects it), HOLOSYM_SINGULAR_MATRIX (no
        !! tangent map at this solution). On failure q, p, dq and dp are unchanged.
        module subroutine integrator_step_tangent(self, sys, q, p, h, dq, dp, info, status)
            class(constrained_integrator), intent(inout) :: self !! the integrator
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(inout) :: q(:)     !! coordinates (n): q_a in, q_b out
            real(wp), intent(inout) :: p(:)     !! momenta (n): p_a in, p_b out
            real(wp), intent(in) :: h           !! step size > 0
            real(wp), intent(inout) :: dq(:, :) !! n x k: tangent vectors' q parts
            real(wp), intent(inout) :: dp(:, :) !! n x k: tangent vectors' p parts
            type(step_info_t), intent(out), optional :: info !! diagnostics of the step
            type(holosym_status_t), intent(out), optional :: status !! outcome
        end subroutine integrator_step_tangent
    end interface
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
        self%path = path_t()
        self%structured_at_init = self%structured
        if (local%ok() .and. self%structured) then
            allocate (mass(sys%n))
            if (reduced_structure(sys, mass)) self%path%main = STEP_REDUCED
        end if
        if (local%ok() .and. self%path%main == STEP_REDUCED) &
            call self%reduced%init(sys, M, N, G, local)
        ! The general scheme's workspace is dense (cubic in the size): as the reduced step's
        ! fallback only for small systems.
        self%path%general_ready = self%path%main == STEP_GENERAL .or. &
            scheme%nx <= general_fallback_size
        if (local%ok() .and. self%path%general_ready) &
            call scheme%init(M, N, G, sys%n, sys%m, local)
        if (.not. local%ok()) then
            self%ready = .false.
            call set_status(status, local%code, local%message)
            return
        end if
        self%scheme = scheme
        self%tangent_ready = .false.
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
        if (.not. self%path%general_ready) nx = 0
        allocate (self%x_work(nx), self%dq_work(sys%n), self%dp_work(sys%n), &
                  self%q_end_work(sys%n), self%p_end_work(sys%n), self%hp_work(sys%n))
        self%last_energy_known = .false.
        self%dependent_nodes = ""
        allocate (self%last_x(nx), self%last_qa(sys%n), self%last_pa(sys%n), &
                  self%last_qb(sys%n), self%last_pb(sys%n))
        ! A fresh workspace: nothing learnt by an earlier run (kept factors, the
        ! quadratic-convergence constant) may change the results of this one.
        self%workspace = newton_workspace_t()
        if (self%path%general_ready) call self%workspace%setup(scheme%nx)
        self%path%last = self%path%main
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

    !> Zero the work counters `stats`.
    subroutine integrator_reset_statistics(self)
        class(constrained_integrator), intent(inout) :: self
        self%stats = integrator_stats_t()
    end subroutine integrator_reset_statistics

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
        if (local%ok()) call forget_unless_continuing(self, q, p)
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

    !> A step or run that does not continue the last step depends only on its arguments:
    !! the factors and habits the iteration learnt in earlier steps are forgotten.
    subroutine forget_unless_continuing(self, q, p)
        class(constrained_integrator), intent(inout) :: self
        real(wp), intent(in) :: q(:), p(:) !! the start state
        if (continues_last_step(self, q, p)) return
        call self%workspace%reset()
        if (self%path%main == STEP_REDUCED) call self%reduced%forget()
    end subroutine forget_unless_continuing

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
        call forget_unless_continuing(self, q, p)
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
            call path_dense(self, tau, q, p, lambda)
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
