!> Measurements at the extremes behind `holosym extremes`: long runs and the growth of
!! round-off, tiny steps, high orders, large steps, stiff springs and near-singular
!! constraints. Each study fills a result type, which the command formats;
!! `extremes_settings(quick=.true.)` gives the shortened sizes of `extremes --quick`.
!!
!! Error measures: the relative energy error |H - H0| / |H0| (the paper's), the constraint
!! residual max |phi| at the displacement nodes (from the step diagnostics) and, for the
!! spherical pendulum, the angular momentum L_z = x p_y - y p_x. H and phi are invariant
!! under rotations about the z axis and the scheme is a Galerkin variational integrator
!! built from those functions alone, so it conserves L_z exactly (discrete Noether theorem):
!! any change of L_z is round-off, at every step size. That makes L_z the measure of how
!! round-off accumulates with the step count.
!!
!! A library module so that the `holosym extremes` command and the tests run the same
!! studies. Internal: no stability promise.
module holosym_study_extremes
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator, step_observer, step_info_t
    use holosym_models, only: spherical_pendulum, spring_linkage
    use holosym_quadrature, only: gauss_legendre, gauss_lobatto
    use holosym_lagrange, only: lagrange_matrices
    use holosym_linalg, only: lu_factor, lu_solve
    use holosym_newton, only: newton_settings_t, newton_report_t, newton_solve
    use holosym_scheme, only: discrete_scheme
    use holosym_manifold, only: manifold_residuals, manifold_tolerance_default
    use holosym_projection, only: project_to_manifold
    use holosym_study_systems, only: make_system
    implicit none
    private

    public :: extremes_settings_t, extremes_settings
    public :: long_run_result_t, run_long_study
    public :: growth_result_t, run_growth_study
    public :: tiny_cell_t, run_tiny_study
    public :: high_order_row_t, run_high_order_study
    public :: large_step_cell_t, run_large_step_study
    public :: stiff_cell_t, run_stiff_study
    public :: near_singular_cell_t, run_near_singular_study
    public :: fitted_exponent, pendulum_angular_momentum
    public :: gauss_rule_error, lobatto_rule_error, basis_error, jacobian_conditioning
    public :: run_monitor, monitor_start, search_largest_step

    real(wp), parameter :: eps = epsilon(1.0_wp)

    !> The paper's best low-order scheme N = M - 1 = G - 2 = 1 and its Fig. 1 step h = 1/8.
    integer, parameter, public :: paper_order_m = 2, paper_order_n = 1, paper_gauss = 3
    real(wp), parameter, public :: paper_step = 0.125_wp
    !> Largest M of the high-order study (G = 16 Gauss points).
    integer, parameter, public :: max_study_order = 15
    !> Errors at or below this are round-off, not truncation: 2**20 epsilon (2.0e-28),
    !! the round-off of a few thousand steps with some margin (as in the tables command).
    real(wp), parameter, public :: error_floor = 1048576 * eps
    !> Geometric blocks of the long run grow by this factor (about one block per 0.6 decade).
    integer, parameter :: long_block_factor = 4
    !> Blocks of the growth ensemble double: enough points for a slope fit.
    integer, parameter :: growth_block_factor = 2
    !> Blocks ending before this step hold too few samples for the growth fit.
    integer, parameter :: fit_first_block_end = 16
    !> Reference of the tiny-step study: M = 8 (order 16) with steps of at most 1/8,
    !! checked against half those steps.
    integer, parameter :: reference_order = 8
    real(wp), parameter :: reference_step = 0.125_wp
    !> Large-step search: start at h = 1/8, double up to h_cap, halve down to h_floor, then
    !! bisect (geometrically) the bracket this many times (resolution 2**(-12) in log2 h).
    real(wp), parameter :: search_start = 0.125_wp
    !> A step of 64 is ten periods of the pendulum; beyond it convergence is meaningless.
    real(wp), parameter :: search_cap = 64.0_wp
    !> Below 2**(-20) a step that fails is not a large-step failure.
    real(wp), parameter :: search_floor = 2.0_wp**(-20)
    integer, parameter :: bisection_steps = 12
    !> Time span of the large-step run criterion: T = 10 as in the tables command.
    real(wp), parameter :: large_run_span = 10.0_wp

    !> Sizes of all studies; `extremes_settings(quick)` gives the full or the short set.
    type :: extremes_settings_t
        integer :: long_steps = 1000000 !! long run: steps
        integer :: long_window = 10000  !! long run: early window for the drift ratio
        integer :: growth_steps = 16384 !! round-off growth: steps per run
        integer :: growth_realizations = 8 !! round-off growth: rotated copies of the state
        integer, allocatable :: tiny_orders(:)  !! tiny steps: M values (N = M-1, G = M+1)
        real(wp), allocatable :: tiny_steps(:)  !! tiny steps: step sizes
        integer :: tiny_step_count = 1000       !! tiny steps: steps per run
        integer :: high_max_order = max_study_order !! high orders: M = 1..this
        real(wp), allocatable :: high_steps(:)  !! high orders: step sizes, largest first
        real(wp) :: high_span = 8               !! high orders: span of each run
        integer :: large_max_order = 8          !! large steps: M = 1..this, both systems
        real(wp), allocatable :: stiffnesses(:) !! stiff: spring constants k
        integer, allocatable :: stiff_orders(:) !! stiff: M values (N = M-1, G = M+1)
        real(wp), allocatable :: stiff_omega_h(:) !! stiff: omega h values
        real(wp) :: stiff_periods = 10          !! stiff: span in spring periods
        real(wp), allocatable :: deltas(:)      !! near-singular: rod excess delta over 2R
        integer :: near_steps = 32              !! near-singular: steps per run
        real(wp) :: near_step = 1.0_wp / 64     !! near-singular: step size
        !> Most steps of any run of any study (huge: no bound; `bound_steps` sets it).
        integer :: max_steps = huge(1)
    end type extremes_settings_t

    !> Study 1: the long run of the spherical pendulum.
    type :: long_run_result_t
        integer :: steps = 0        !! steps requested
        integer :: steps_done = 0   !! steps completed
        integer :: window = 0       !! early window (steps) for the drift ratio
        integer :: code = HOLOSYM_SUCCESS       !! status of the run
        character(len=:), allocatable :: message !! its message
        real(wp) :: energy_window = 0  !! max relative energy error over the early window
        real(wp) :: energy_total = 0   !! max relative energy error over the whole run
        real(wp) :: constraint_max = 0 !! max |phi| at the displacement nodes, all steps
        real(wp) :: velocity_max = 0   !! max |Phi H_p| at the step ends, all steps
        real(wp) :: iterations = 0     !! mean Newton iterations per step
        integer, allocatable :: block_end(:)     !! last step of each block
        real(wp), allocatable :: block_energy(:) !! max relative energy error in the block
        real(wp), allocatable :: block_lz(:)     !! RMS of L_z - L_z(0) over the block
        real(wp) :: lz_exponent = 0  !! fitted growth exponent of block_lz
        real(wp) :: seconds = 0      !! wall time
    end type long_run_result_t

    !> Round-off growth: RMS change of L_z over rotated copies of the start state, with the
    !! compensated summation of `integrate` and with naive summation (a loop of `step`), on
    !! the default (reduced) path, and with `integrate` on the general path.
    type :: growth_result_t
        integer :: steps = 0         !! steps per run
        integer :: realizations = 0  !! rotated copies
        integer :: code = HOLOSYM_SUCCESS        !! first failure, if any
        character(len=:), allocatable :: message !! its message
        integer, allocatable :: block_end(:)          !! block ends (doubling)
        real(wp), allocatable :: rms_compensated(:)   !! RMS of L_z - L_z(0), compensated
        real(wp), allocatable :: rms_naive(:)         !! the same with naive summation
        real(wp), allocatable :: rms_general(:)       !! compensated, general path
        real(wp) :: exponent_compensated = 0 !! fitted exponent (1/2 for a random walk)
        real(wp) :: exponent_naive = 0       !! fitted exponent, naive summation
        real(wp) :: exponent_general = 0     !! fitted exponent, general path
        real(wp) :: seconds = 0
    end type growth_result_t

    !> Study 2: one run of the tiny-step study.
    type :: tiny_cell_t
        integer :: order_m = 0, order_n = 0, gauss_points = 0 !! (M, N, G)
        real(wp) :: h = 0          !! step size
        integer :: steps = 0       !! steps
        integer :: code = HOLOSYM_SUCCESS        !! status
        character(len=:), allocatable :: message !! its message
        real(wp) :: energy_error = 0   !! max relative energy error over the run
        real(wp) :: global_error = 0   !! max |q(steps h) - q_ref|
        real(wp) :: reference_change = 0 !! |q_ref(h_ref) - q_ref(h_ref/2)|
    end type tiny_cell_t

    !> Study 3: one order M of the high-order study (N = M - 1, G = M + 1).
    type :: high_order_row_t
        integer :: order_m = 0, order_n = 0, gauss_points = 0 !! (M, N, G)
        real(wp) :: gauss_error = 0   !! Gauss-Legendre G points: max monomial error, deg <= 2G-1
        real(wp) :: lobatto_error = 0 !! Lobatto M+1 points: max monomial error, deg <= 2M-1
        real(wp) :: basis_error = 0   !! Lagrange basis on the M+1 Lobatto nodes: max error of
                                      !! tau^k and k tau^(k-1) (k <= M) at the Gauss points
        integer :: conditioning_code = HOLOSYM_SUCCESS !! status of the first step
        real(wp) :: pivot_ratio = 0   !! smallest relative pivot, first step (h = 1/8)
        real(wp) :: condition = 0     !! 1-norm condition number of the row-equilibrated
                                      !! Newton Jacobian at the first step's solution
        integer :: newton_iterations = 0 !! iterations of that step
        real(wp), allocatable :: energy_error(:) !! per step size; 0 when not run
        integer, allocatable :: codes(:)         !! per step size; status
        logical, allocatable :: ran(:)           !! per step size: run attempted
        real(wp) :: order = 0                 !! observed order (last pair above the floor)
        logical :: order_measured = .false.   !! whether such a pair exists
        real(wp) :: order_h(2) = 0            !! its step sizes
        real(wp) :: seconds = 0
    end type high_order_row_t

    !> Study 4: the largest step on one system and order.
    type :: large_step_cell_t
        character(len=:), allocatable :: system  !! pendulum or linkage
        integer :: order_m = 0, order_n = 0, gauss_points = 0 !! (M, N, G)
        real(wp) :: h_step = 0       !! largest h found for which the first step converges
        real(wp) :: h_step_fail = 0  !! the failing h just above it
        integer :: step_fail_code = HOLOSYM_SUCCESS !! status at h_step_fail
        character(len=:), allocatable :: step_fail_message !! its message
        logical :: step_fail_clean = .false. !! code > 0, q and p unchanged and finite
        real(wp) :: h_run = 0        !! largest h found for which a run over T = 10 completes
        real(wp) :: h_run_fail = 0   !! the failing h just above it
        integer :: run_fail_code = HOLOSYM_SUCCESS  !! status at h_run_fail
        integer :: run_fail_steps = 0               !! steps completed there
        logical :: run_fail_clean = .false. !! code > 0, state finite and on the manifold
        real(wp) :: run_energy_error = 0    !! max relative energy error of the run at h_run
        logical :: capped = .false.  !! converged up to the search cap (64)
        real(wp) :: seconds = 0
    end type large_step_cell_t

    !> Study 5: one run on the stiff spring-linkage.
    type :: stiff_cell_t
        real(wp) :: stiffness = 0  !! k [N/m]
        integer :: order_m = 0, order_n = 0, gauss_points = 0 !! (M, N, G)
        real(wp) :: omega_h = 0    !! sqrt(k/m_r) h
        real(wp) :: h = 0          !! step size
        integer :: steps = 0       !! steps requested (the span is a number of periods)
        integer :: steps_done = 0  !! steps completed
        integer :: code = HOLOSYM_SUCCESS        !! status
        character(len=:), allocatable :: message !! its message
        real(wp) :: energy_error = 0    !! max relative energy error
        real(wp) :: constraint_max = 0  !! max |phi| at the displacement nodes
        real(wp) :: iterations = 0      !! mean Newton iterations per step
    end type stiff_cell_t

    !> Study 6: the linkage with rod length L = 2R(1 + delta), started next to the
    !! configuration where the three constraint gradients become dependent.
    type :: near_singular_cell_t
        real(wp) :: delta = 0       !! relative excess of L over 2R
        real(wp) :: gram_pivot = 0  !! smallest relative pivot of Phi Phi^T at the start
        integer :: projection_code = HOLOSYM_SUCCESS !! status of project_to_manifold
        integer :: code = HOLOSYM_SUCCESS            !! status of the run
        character(len=:), allocatable :: message     !! its message
        integer :: steps_done = 0
        real(wp) :: lambda_max = 0       !! max |lambda| over the run
        real(wp) :: newton_pivot = 0     !! smallest Newton pivot ratio over the run
        real(wp) :: constraint_max = 0   !! max |phi| at the displacement nodes
        real(wp) :: energy_error = 0     !! max relative energy error
    end type near_singular_cell_t

    !> Observer collecting the maxima and block statistics of a run.
    type, extends(step_observer) :: run_monitor
        class(constrained_hamiltonian), allocatable :: sys !! the system, for H
        real(wp) :: energy0 = 0        !! H at the start
        real(wp) :: energy_scale = 1   !! |H0|, or 1 when H0 = 0
        real(wp) :: lz0 = 0            !! L_z at the start (with `track_lz`)
        logical :: track_lz = .false.  !! record L_z (spherical pendulum)
        integer :: window = 0          !! early window of the drift ratio (steps)
        real(wp) :: energy_window = 0  !! max relative energy error in the window
        real(wp) :: energy_max = 0     !! max relative energy error
        real(wp) :: constraint_max = 0 !! max |phi| at the displacement nodes
        real(wp) :: velocity_max = 0   !! max |Phi H_p| at the step ends
        real(wp) :: lambda_max = 0     !! max |lambda|
        real(wp) :: pivot_min = huge(1.0_wp) !! smallest Newton pivot ratio
        integer :: iterations = 0      !! Newton iterations of the run
        integer :: steps = 0           !! steps recorded
        integer, allocatable :: block_end(:)     !! last step of each block
        real(wp), allocatable :: block_energy(:) !! max relative energy error per block
        real(wp), allocatable :: block_lz2(:)    !! sum of squared L_z changes per block
        integer, allocatable :: block_count(:)   !! steps per block
        integer :: block = 1                     !! the current block
        integer :: progress_unit = -1            !! unit of progress lines (-1: none)
        integer :: progress_every = 0            !! steps between progress lines (0: none)
        character(len=:), allocatable :: label   !! start of each progress line
        !> L_z - L_z(0) after each step, with `track_lz` and when allocated by the caller
        !! (one entry per step; steps beyond its size are not recorded).
        real(wp), allocatable :: lz_error(:)
    contains
        procedure :: observe => monitor_observe
    end type run_monitor

contains

    !> pi in working precision (a function: real128 atan is not folded by every compiler).
    pure real(wp) function pi()
        pi = 4 * atan(1.0_wp)
    end function pi

    ! ------------------------------------------------------------------ settings, helpers

    !> The sizes of the full report (`quick = .false.`) or of the short one (`.true.`).
    function extremes_settings(quick) result(settings)
        logical, intent(in) :: quick !! the short set (under a minute in the release build)
        type(extremes_settings_t) :: settings
        integer :: j
        settings%tiny_orders = [1, 2, 3, 4]
        settings%high_steps = [2.0_wp, 1.0_wp, 0.5_wp, 0.25_wp, 0.125_wp, 0.0625_wp]
        settings%stiffnesses = [1.0e4_wp, 1.0e6_wp]
        settings%stiff_orders = [2, 3]
        settings%stiff_omega_h = [8.0_wp, 4.0_wp, 2.0_wp, 1.0_wp, 0.5_wp, 0.25_wp, 0.125_wp, &
                                  0.0625_wp]
        settings%deltas = [1.0e-1_wp, 1.0e-2_wp, 1.0e-4_wp, 1.0e-8_wp, 1.0e-12_wp, 1.0e-16_wp, &
                           1.0e-20_wp, 1.0e-24_wp, 1.0e-28_wp, 1.0e-30_wp, 1.0e-32_wp, &
                           1.0e-33_wp, 0.0_wp]
        ! Half decades from 1e-2 to 1e-6.
        settings%tiny_steps = [(10.0_wp**(-2 - 0.5_wp * j), j = 0, 8)]
        if (quick) then
            settings%long_steps = 20000
            settings%long_window = 2000
            settings%growth_steps = 1024
            settings%growth_realizations = 4
            settings%tiny_steps = [(10.0_wp**(-j), j = 2, 6)]
            settings%tiny_step_count = 100
            settings%high_max_order = 6
            settings%high_steps = [1.0_wp, 0.5_wp, 0.25_wp, 0.125_wp]
            settings%high_span = 4
            settings%large_max_order = 3
            settings%stiff_orders = [2]
            settings%stiff_omega_h = [4.0_wp, 1.0_wp, 0.25_wp]
            settings%stiff_periods = 2
            settings%deltas = [1.0e-2_wp, 1.0e-8_wp, 1.0e-16_wp, 1.0e-32_wp, 0.0_wp]
            settings%near_steps = 8
        end if
    end function extremes_settings

    !> L_z = x p_y - y p_x of the spherical pendulum (conserved by the scheme).
    pure real(wp) function pendulum_angular_momentum(q, p)
        real(wp), intent(in) :: q(:) !! (x, y, z)
        real(wp), intent(in) :: p(:) !! (p_x, p_y, p_z)
        pendulum_angular_momentum = q(1) * p(2) - q(2) * p(1)
    end function pendulum_angular_momentum

    !> Least-squares slope of log(values) against log(points), over positive values:
    !! the exponent a of values ~ C points**a (0 when fewer than two points qualify).
    pure real(wp) function fitted_exponent(points, values)
        real(wp), intent(in) :: points(:) !! abscissae (> 0)
        real(wp), intent(in) :: values(:) !! ordinates; non-positive ones are skipped
        real(wp) :: x(size(points)), y(size(points)), mean_x, mean_y
        integer :: k, used
        used = 0
        do k = 1, size(points)
            if (values(k) > 0 .and. points(k) > 0) then
                used = used + 1
                x(used) = log(points(k))
                y(used) = log(values(k))
            end if
        end do
        fitted_exponent = 0
        if (used < 2) return
        mean_x = sum(x(:used)) / used
        mean_y = sum(y(:used)) / used
        if (sum((x(:used) - mean_x)**2) <= 0) return
        fitted_exponent = sum((x(:used) - mean_x) * (y(:used) - mean_y)) / &
                          sum((x(:used) - mean_x)**2)
    end function fitted_exponent

    !> Block ends factor, factor**2, ... below `steps`, then `steps`.
    pure function geometric_blocks(steps, factor) result(ends)
        integer, intent(in) :: steps  !! steps of the run
        integer, intent(in) :: factor !! growth factor of the blocks
        integer, allocatable :: ends(:)
        integer :: last
        allocate (ends(0))
        if (steps < 1) return
        last = factor
        do while (last < steps)
            ends = [ends, last]
            if (last > huge(last) / factor) exit
            last = last * factor
        end do
        ends = [ends, steps]
    end function geometric_blocks

    !> Mean step of block k: (start + end) / 2, where a random walk's mean square is taken.
    pure function block_centres(ends) result(centres)
        integer, intent(in) :: ends(:) !! last step of each block
        real(wp) :: centres(size(ends))
        integer :: k, start
        start = 0
        do k = 1, size(ends)
            centres(k) = (real(start + 1, wp) + ends(k)) / 2
            start = ends(k)
        end do
    end function block_centres

    !> Set up a monitor for a run of `steps` from (q, p), with blocks growing by `factor`.
    subroutine monitor_start(monitor, sys, q, p, steps, factor, track_lz, window)
        type(run_monitor), intent(out) :: monitor        !! the monitor
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:)                      !! start coordinates
        real(wp), intent(in) :: p(:)                      !! start momenta
        integer, intent(in) :: steps                      !! steps of the run
        integer, intent(in) :: factor                     !! growth factor of the blocks
        logical, intent(in) :: track_lz                   !! record L_z (spherical pendulum)
        integer, intent(in) :: window                     !! early window of the drift ratio
        allocate (monitor%sys, source=sys)
        monitor%energy0 = sys%hamiltonian(q, p)
        monitor%energy_scale = abs(monitor%energy0)
        if (.not. monitor%energy_scale > 0) monitor%energy_scale = 1
        monitor%track_lz = track_lz
        if (track_lz) monitor%lz0 = pendulum_angular_momentum(q, p)
        monitor%window = window
        monitor%block_end = geometric_blocks(steps, factor)
        allocate (monitor%block_energy(size(monitor%block_end)), &
                  monitor%block_lz2(size(monitor%block_end)), &
                  monitor%block_count(size(monitor%block_end)))
        monitor%block_energy = 0
        monitor%block_lz2 = 0
        monitor%block_count = 0
        monitor%label = ""
    end subroutine monitor_start

    !> Record one step.
    subroutine monitor_observe(self, step, t, q, p, info, halt)
        class(run_monitor), intent(inout) :: self !! the monitor
        integer, intent(in) :: step           !! step number
        real(wp), intent(in) :: t             !! time
        real(wp), intent(in) :: q(:)          !! coordinates after the step
        real(wp), intent(in) :: p(:)          !! momenta after the step
        type(step_info_t), intent(in) :: info !! diagnostics of the step
        logical, intent(inout) :: halt        !! not set
        real(wp) :: energy_error, lz_error
        energy_error = abs(self%sys%hamiltonian(q, p) - self%energy0) / self%energy_scale
        self%steps = step
        self%energy_max = max(self%energy_max, energy_error)
        if (step <= self%window) self%energy_window = max(self%energy_window, energy_error)
        self%constraint_max = max(self%constraint_max, info%constraint_residual)
        self%velocity_max = max(self%velocity_max, info%velocity_residual)
        self%iterations = self%iterations + info%newton_iterations
        self%pivot_min = min(self%pivot_min, info%pivot_ratio)
        if (allocated(info%lambda)) then
            if (size(info%lambda) > 0) self%lambda_max = max(self%lambda_max, &
                                                             maxval(abs(info%lambda)))
        end if
        do while (self%block < size(self%block_end))
            if (step <= self%block_end(self%block)) exit
            self%block = self%block + 1
        end do
        lz_error = 0
        if (self%track_lz) lz_error = pendulum_angular_momentum(q, p) - self%lz0
        if (self%track_lz .and. allocated(self%lz_error)) then
            if (step <= size(self%lz_error)) self%lz_error(step) = lz_error
        end if
        if (size(self%block_end) > 0) then
            self%block_energy(self%block) = max(self%block_energy(self%block), energy_error)
            if (self%track_lz) self%block_lz2(self%block) = self%block_lz2(self%block) + &
                lz_error**2
            self%block_count(self%block) = self%block_count(self%block) + 1
        end if
        if (self%progress_unit >= 0 .and. self%progress_every > 0) then
            if (mod(step, self%progress_every) == 0) then
                write (self%progress_unit, '(a)') self%label // int_str(step) // &
                    " steps, max energy error " // real_str(self%energy_max)
                flush (self%progress_unit)
            end if
        end if
    end subroutine monitor_observe

    !> Wall-clock seconds since `start` (a system_clock count).
    real(wp) function seconds_since(start)
        integer(int64), intent(in) :: start !! a system_clock count
        integer(int64) :: now, rate
        call system_clock(now, rate)
        seconds_since = real(now - start, wp) / rate
    end function seconds_since

    !> The current system_clock count.
    integer(int64) function clock_now()
        call system_clock(clock_now)
    end function clock_now

    !> Write a progress line when a unit is given.
    subroutine progress(unit, text)
        integer, intent(in), optional :: unit !! the unit of progress lines
        character(len=*), intent(in) :: text  !! the line, after "extremes: "
        if (present(unit)) then
            write (unit, '(a)') "extremes: " // text
            flush (unit)
        end if
    end subroutine progress

    ! ------------------------------------------------------------------ 1. long run

    !> Study 1: `steps` steps of the spherical pendulum from the paper's state with
    !! (M, N, G) = (2, 1, 3), h = 1/8, through `integrate` (compensated summation).
    !! Codes: HOLOSYM_INVALID_ARGUMENT (steps < 1 or window < 1); a failed run is reported
    !! in `result%code` with the statistics of the steps done.
    subroutine run_long_study(steps, window, result, status, progress_unit)
        integer, intent(in) :: steps   !! steps of the run (>= 1)
        integer, intent(in) :: window  !! early window for the drift ratio (>= 1)
        type(long_run_result_t), intent(out) :: result !! measurements
        type(holosym_status_t), intent(out), optional :: status !! invalid sizes
        integer, intent(in), optional :: progress_unit !! progress lines here
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: monitor
        type(holosym_status_t) :: local
        real(wp) :: q(3), p(3)
        integer(int64) :: start

        if (steps < 1 .or. window < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "long run needs steps >= 1 and " &
                // "window >= 1; got " // int_str(steps) // " and " // int_str(window))
            return
        end if
        start = clock_now()
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        result%steps = steps
        result%window = min(window, steps)
        call monitor_start(monitor, sys, q, p, steps, long_block_factor, .true., result%window)
        if (present(progress_unit)) then
            monitor%progress_unit = progress_unit
            monitor%progress_every = max(steps / 10, 1)
            monitor%label = "extremes: long run: "
        end if
        call integrator%init(sys, paper_order_m, paper_order_n, paper_gauss, local)
        if (local%ok()) call integrator%integrate(sys, q, p, paper_step, steps, monitor, &
                                                  result%steps_done, local)
        result%code = local%code
        result%message = local%message
        result%energy_window = monitor%energy_window
        result%energy_total = monitor%energy_max
        result%constraint_max = monitor%constraint_max
        result%velocity_max = monitor%velocity_max
        result%iterations = real(monitor%iterations, wp) / max(monitor%steps, 1)
        result%block_end = monitor%block_end
        result%block_energy = monitor%block_energy
        result%block_lz = sqrt(monitor%block_lz2 / max(monitor%block_count, 1))
        result%lz_exponent = fitted_exponent(fit_points(result%block_end), &
                                             fit_values(result%block_end, result%block_lz))
        result%seconds = seconds_since(start)
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine run_long_study

    !> Block centres used by the growth fits (blocks ending at or after fit_first_block_end).
    pure function fit_points(ends) result(points)
        integer, intent(in) :: ends(:) !! last step of each block
        real(wp) :: points(size(ends))
        points = block_centres(ends)
        where (ends < fit_first_block_end) points = 0
    end function fit_points

    !> Values matching `fit_points` (0, i.e. skipped, for the early blocks).
    pure function fit_values(ends, values) result(used)
        integer, intent(in) :: ends(:)    !! last step of each block
        real(wp), intent(in) :: values(:) !! one value per block
        real(wp) :: used(size(values))
        used = values
        where (ends < fit_first_block_end) used = 0
    end function fit_values

    !> Round-off growth: `realizations` copies of the paper's pendulum state rotated about
    !! the z axis (then projected onto the manifold), each run for `steps` steps at h = 1/8
    !! with (2, 1, 3): with `integrate` (compensated summation), as a loop of `step` (naive
    !! summation q <- q + dq), and with `integrate` on the general path
    !! (`structured = .false.`). The RMS of L_z - L_z(0) over each doubling block and all
    !! copies, and its fitted growth exponent (1/2: a random walk; 1: a drift).
    !! Codes: HOLOSYM_INVALID_ARGUMENT (steps < 2 or realizations < 1); a failed run is
    !! reported in `result%code`.
    subroutine run_growth_study(steps, realizations, result, status, progress_unit)
        integer, intent(in) :: steps        !! steps per run (>= 2)
        integer, intent(in) :: realizations !! rotated copies (>= 1)
        type(growth_result_t), intent(out) :: result !! measurements
        type(holosym_status_t), intent(out), optional :: status !! invalid sizes
        integer, intent(in), optional :: progress_unit !! progress lines here
        integer, parameter :: variants = 3
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: monitor
        type(holosym_status_t) :: local
        type(step_info_t) :: info
        real(wp) :: q0(3), p0(3), q(3), p(3), qr(3), pr(3), angle
        real(wp), allocatable :: sums(:, :)
        integer, allocatable :: counts(:, :)
        integer :: r, k, variant, done
        integer(int64) :: start
        logical :: halt

        if (steps < 2 .or. realizations < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "growth study needs steps >= 2 " &
                // "and realizations >= 1; got " // int_str(steps) // " and " // &
                int_str(realizations))
            return
        end if
        start = clock_now()
        result%steps = steps
        result%realizations = realizations
        result%message = ""
        result%block_end = geometric_blocks(steps, growth_block_factor)
        allocate (sums(size(result%block_end), variants), counts(size(result%block_end), variants))
        sums = 0
        counts = 0
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        do r = 1, realizations
            angle = 2 * pi() * (r - 1) / realizations
            q = [cos(angle) * q0(1) - sin(angle) * q0(2), sin(angle) * q0(1) + cos(angle) * q0(2), &
                 q0(3)]
            p = [cos(angle) * p0(1) - sin(angle) * p0(2), sin(angle) * p0(1) + cos(angle) * p0(2), &
                 p0(3)]
            call project_to_manifold(sys, q, p, local)
            if (.not. local%ok()) exit
            do variant = 1, variants
                call monitor_start(monitor, sys, q, p, steps, growth_block_factor, .true., steps)
                integrator%structured = variant /= 3
                call integrator%init(sys, paper_order_m, paper_order_n, paper_gauss, local)
                if (.not. local%ok()) exit
                qr = q
                pr = p
                if (variant /= 2) then
                    call integrator%integrate(sys, qr, pr, paper_step, steps, monitor, done, &
                                              local)
                else
                    halt = .false.
                    do k = 1, steps
                        call integrator%step(sys, qr, pr, paper_step, info, local)
                        if (.not. local%ok()) exit
                        call monitor%observe(k, k * paper_step, qr, pr, info, halt)
                    end do
                end if
                if (.not. local%ok()) exit
                sums(:, variant) = sums(:, variant) + monitor%block_lz2
                counts(:, variant) = counts(:, variant) + monitor%block_count
            end do
            if (.not. local%ok()) exit
            call progress(progress_unit, "round-off growth: copy " // int_str(r) // "/" // &
                int_str(realizations) // " done")
        end do
        result%code = local%code
        result%message = local%message
        result%rms_compensated = sqrt(sums(:, 1) / max(counts(:, 1), 1))
        result%rms_naive = sqrt(sums(:, 2) / max(counts(:, 2), 1))
        result%rms_general = sqrt(sums(:, 3) / max(counts(:, 3), 1))
        result%exponent_compensated = growth_exponent(result%rms_compensated)
        result%exponent_naive = growth_exponent(result%rms_naive)
        result%exponent_general = growth_exponent(result%rms_general)
        result%seconds = seconds_since(start)
        call set_status(status, HOLOSYM_SUCCESS, "")

    contains

        !> Fitted growth exponent of an RMS column over the blocks.
        real(wp) function growth_exponent(rms)
            real(wp), intent(in) :: rms(:) !! one RMS value per block
            growth_exponent = fitted_exponent(fit_points(result%block_end), &
                                              fit_values(result%block_end, rms))
        end function growth_exponent

    end subroutine run_growth_study

    ! ------------------------------------------------------------------ 2. tiny steps

    !> Study 2: for each M in `orders` (N = M - 1, G = M + 1) and each h in `step_sizes`,
    !! `steps` steps of the pendulum from the paper's state: the max relative energy error
    !! and the error of q(steps h) against an M = 8 reference (steps of at most 1/8, checked
    !! against half of them). `cells(i, j)` is step size i, order j.
    !! Codes: HOLOSYM_INVALID_ARGUMENT (empty lists, steps < 1, h <= 0, M < 1).
    subroutine run_tiny_study(orders, step_sizes, steps, cells, status, progress_unit)
        integer, intent(in) :: orders(:)       !! M values (>= 1)
        real(wp), intent(in) :: step_sizes(:)  !! h values (> 0)
        integer, intent(in) :: steps           !! steps per run (>= 1)
        type(tiny_cell_t), allocatable, intent(out) :: cells(:, :) !! measurements
        type(holosym_status_t), intent(out), optional :: status !! invalid arguments
        integer, intent(in), optional :: progress_unit !! progress lines here
        type(spherical_pendulum) :: sys
        type(holosym_status_t) :: local
        real(wp) :: q0(3), p0(3), q_ref(3), q_check(3), q_end(3), span, energy
        integer :: i, j, reference_steps

        if (size(orders) < 1 .or. size(step_sizes) < 1 .or. steps < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tiny-step study needs orders, " &
                // "step sizes and steps >= 1; got steps = " // int_str(steps))
            return
        else if (any(orders < 1) .or. .not. all(step_sizes > 0)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tiny-step study needs M >= 1 " &
                // "and h > 0")
            return
        end if
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        allocate (cells(size(step_sizes), size(orders)))
        do i = 1, size(step_sizes)
            span = steps * step_sizes(i)
            reference_steps = max(1, ceiling(span / reference_step))
            ! References by the general scheme: it keeps the momenta as unknowns, while the
            ! reduced step derives them from position differences with |E| ~ M^2 times
            ! the round-off (visible in real64 at M = 8).
            call fixed_run(sys, q0, p0, reference_order, span / reference_steps, &
                           reference_steps, q_ref, energy, local, general=.true.)
            if (local%ok()) call fixed_run(sys, q0, p0, reference_order, &
                span / (2 * reference_steps), 2 * reference_steps, q_check, energy, local, &
                general=.true.)
            do j = 1, size(orders)
                cells(i, j)%order_m = orders(j)
                cells(i, j)%order_n = orders(j) - 1
                cells(i, j)%gauss_points = orders(j) + 1
                cells(i, j)%h = step_sizes(i)
                cells(i, j)%steps = steps
                cells(i, j)%message = ""
                if (.not. local%ok()) then
                    cells(i, j)%code = local%code
                    cells(i, j)%message = "reference: " // local%message
                    cycle
                end if
                cells(i, j)%reference_change = maxval(abs(q_check - q_ref))
            end do
            if (.not. local%ok()) cycle
            !$omp parallel do schedule(dynamic, 1) private(j, q_end, local)
            do j = 1, size(orders)
                call fixed_run(sys, q0, p0, orders(j), step_sizes(i), steps, q_end, &
                               cells(i, j)%energy_error, local)
                cells(i, j)%code = local%code
                cells(i, j)%message = local%message
                if (local%ok()) cells(i, j)%global_error = maxval(abs(q_end - q_check))
            end do
            !$omp end parallel do
            call progress(progress_unit, "tiny steps: h = " // real_str(step_sizes(i)) // " done")
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine run_tiny_study

    !> `steps` steps with (M, M - 1, M + 1) and step h through `integrate`: q at the end and
    !! the max relative energy error.
    subroutine fixed_run(sys, q0, p0, order_m, h, steps, q_end, energy_error, status, general)
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(in) :: q0(:)          !! start coordinates
        real(wp), intent(in) :: p0(:)          !! start momenta
        integer, intent(in) :: order_m         !! M (N = M - 1, G = M + 1)
        real(wp), intent(in) :: h              !! step size
        integer, intent(in) :: steps           !! number of steps
        real(wp), intent(out) :: q_end(:)      !! q after the run
        real(wp), intent(out) :: energy_error  !! max relative energy error
        type(holosym_status_t), intent(out) :: status !! outcome
        !> Use the general scheme (momenta as unknowns) even where the reduced step applies.
        logical, intent(in), optional :: general
        type(constrained_integrator) :: integrator
        type(run_monitor) :: monitor
        real(wp) :: q(size(q0)), p(size(p0))
        q = q0
        p = p0
        call monitor_start(monitor, sys, q, p, steps, growth_block_factor, .false., steps)
        if (present(general)) integrator%structured = .not. general
        call integrator%init(sys, order_m, order_m - 1, order_m + 1, status)
        if (status%ok()) call integrator%integrate(sys, q, p, h, steps, monitor, status=status)
        q_end = q
        energy_error = monitor%energy_max
    end subroutine fixed_run

    ! ------------------------------------------------------------------ 3. high orders

    !> Study 3: for M = 1..max_order (N = M - 1, G = M + 1): accuracy of the quadrature
    !! rules and of the Lagrange basis, the pivot ratio and 1-norm condition number of the
    !! row-equilibrated Newton Jacobian at the first step (h = 1/8), and the energy errors of
    !! pendulum runs over `span` for each h in `step_sizes` (largest first; refinement stops
    !! once an error is at the floor) with the observed order of the last pair above it.
    !! Codes: HOLOSYM_INVALID_ARGUMENT (max_order outside 1..max_study_order, span <= 0,
    !! fewer than two step sizes, h <= 0).
    subroutine run_high_order_study(max_order, step_sizes, span, rows, status, progress_unit, &
                                    max_steps)
        integer, intent(in) :: max_order        !! largest M, 1..max_study_order
        real(wp), intent(in) :: step_sizes(:)   !! h values, largest first (> 0)
        real(wp), intent(in) :: span            !! time span of each run (> 0)
        type(high_order_row_t), allocatable, intent(out) :: rows(:) !! one per M
        type(holosym_status_t), intent(out), optional :: status !! invalid arguments
        integer, intent(in), optional :: progress_unit !! progress lines here
        integer, intent(in), optional :: max_steps !! most steps of a run (default: none)
        type(spherical_pendulum), target :: sys
        real(wp) :: q0(3), p0(3)
        integer :: order_m, limit

        limit = huge(1)
        if (present(max_steps)) limit = max_steps
        if (max_order < 1 .or. max_order > max_study_order) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "high-order study needs 1 <= " // &
                "M <= " // int_str(max_study_order) // "; got " // int_str(max_order))
            return
        else if (.not. span > 0 .or. size(step_sizes) < 2 .or. .not. all(step_sizes > 0)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "high-order study needs span " // &
                "> 0 and at least two step sizes > 0; got span = " // real_str(span))
            return
        end if
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        allocate (rows(max_order))
        !$omp parallel do schedule(dynamic, 1) private(order_m)
        do order_m = max_order, 1, -1
            call high_order_row(sys, q0, p0, order_m, step_sizes, span, rows(order_m), limit)
            !$omp critical (extremes_progress)
            call progress(progress_unit, "high orders: M = " // int_str(order_m) // " done")
            !$omp end critical (extremes_progress)
        end do
        !$omp end parallel do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine run_high_order_study

    !> One row of the high-order study.
    subroutine high_order_row(sys, q0, p0, order_m, step_sizes, span, row, max_steps)
        type(spherical_pendulum), intent(in), target :: sys !! the pendulum
        real(wp), intent(in) :: q0(:)          !! start coordinates
        real(wp), intent(in) :: p0(:)          !! start momenta
        integer, intent(in) :: order_m         !! M (N = M - 1, G = M + 1)
        real(wp), intent(in) :: step_sizes(:)  !! step sizes, largest first
        real(wp), intent(in) :: span           !! time span of each run
        type(high_order_row_t), intent(out) :: row !! the row
        type(holosym_status_t) :: local
        real(wp) :: q_end(3)
        integer, intent(in) :: max_steps !! most steps of a run
        integer :: k, steps
        integer(int64) :: start

        start = clock_now()
        row%order_m = order_m
        row%order_n = order_m - 1
        row%gauss_points = order_m + 1
        row%gauss_error = gauss_rule_error(row%gauss_points)
        row%lobatto_error = lobatto_rule_error(order_m + 1)
        row%basis_error = basis_error(order_m)
        call jacobian_conditioning(sys, q0, p0, order_m, paper_step, row%pivot_ratio, &
                                   row%condition, row%newton_iterations, row%conditioning_code)
        allocate (row%energy_error(size(step_sizes)), row%codes(size(step_sizes)), &
                  row%ran(size(step_sizes)))
        row%energy_error = 0
        row%codes = HOLOSYM_SUCCESS
        row%ran = .false.
        do k = 1, size(step_sizes)
            steps = min(max(1, nint(span / step_sizes(k))), max_steps)
            row%ran(k) = .true.
            call fixed_run(sys, q0, p0, order_m, step_sizes(k), steps, q_end, &
                           row%energy_error(k), local)
            row%codes(k) = local%code
            if (local%ok() .and. row%energy_error(k) <= error_floor) exit
        end do
        do k = size(step_sizes), 2, -1
            if (.not. (row%ran(k) .and. row%ran(k - 1))) cycle
            if (row%codes(k) /= HOLOSYM_SUCCESS .or. row%codes(k - 1) /= HOLOSYM_SUCCESS) cycle
            if (row%energy_error(k) > error_floor .and. row%energy_error(k - 1) > error_floor) then
                row%order_h = step_sizes(k - 1:k)
                row%order = log(row%energy_error(k - 1) / row%energy_error(k)) / &
                            log(step_sizes(k - 1) / step_sizes(k))
                row%order_measured = .true.
                exit
            end if
        end do
        row%seconds = seconds_since(start)
    end subroutine high_order_row

    !> Max error of the G-point Gauss-Legendre rule on tau**k, k = 0..2G-1, over [0, 1].
    function gauss_rule_error(points) result(worst)
        integer, intent(in) :: points !! G >= 1
        real(wp) :: worst
        real(wp) :: nodes(points), weights(points)
        integer :: k
        call gauss_legendre(nodes, weights)
        worst = 0
        do k = 0, 2 * points - 1
            worst = max(worst, abs(sum(weights * nodes**k) - 1.0_wp / (k + 1)))
        end do
    end function gauss_rule_error

    !> Max error of the K-point Gauss-Lobatto rule on tau**k, k = 0..2K-3, over [0, 1].
    function lobatto_rule_error(points) result(worst)
        integer, intent(in) :: points !! K >= 2
        real(wp) :: worst
        real(wp) :: nodes(points), weights(points)
        integer :: k
        call gauss_lobatto(nodes, weights)
        worst = 0
        do k = 0, 2 * points - 3
            worst = max(worst, abs(sum(weights * nodes**k) - 1.0_wp / (k + 1)))
        end do
    end function lobatto_rule_error

    !> Max error of the degree-M Lagrange basis on the M+1 Lobatto nodes, evaluated at the
    !! M+1 Gauss points: interpolated tau**k and its derivative k tau**(k-1), k = 0..M.
    function basis_error(order_m) result(worst)
        integer, intent(in) :: order_m !! M >= 1
        real(wp) :: worst
        real(wp) :: nodes(order_m + 1), weights(order_m + 1)
        real(wp) :: points(order_m + 1), gauss_w(order_m + 1)
        real(wp) :: values(order_m + 1, order_m + 1), derivatives(order_m + 1, order_m + 1)
        integer :: k
        call gauss_lobatto(nodes, weights)
        call gauss_legendre(points, gauss_w)
        call lagrange_matrices(nodes, points, values, derivatives)
        worst = 0
        do k = 0, order_m
            worst = max(worst, maxval(abs(matmul(values, nodes**k) - points**k)))
            if (k >= 1) worst = max(worst, maxval(abs(matmul(derivatives, nodes**k) - &
                                                      k * points**(k - 1))))
        end do
    end function basis_error

    !> Solve the first step (cold start) with the scheme directly and measure the Newton
    !! Jacobian at the solution: smallest relative pivot and 1-norm condition number
    !! ||J|| ||J^-1|| of the row-equilibrated matrix (the matrix Newton factors).
    subroutine jacobian_conditioning(sys, q0, p0, order_m, h, pivot_ratio, condition, &
                                     iterations, code)
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(in) :: q0(:)          !! start coordinates
        real(wp), intent(in) :: p0(:)          !! start momenta
        integer, intent(in) :: order_m         !! M (N = M - 1, G = M + 1)
        real(wp), intent(in) :: h              !! step size
        real(wp), intent(out) :: pivot_ratio   !! smallest relative pivot
        real(wp), intent(out) :: condition     !! ||J||_1 ||J^-1||_1 (huge when singular)
        integer, intent(out) :: iterations     !! Newton iterations of the solve
        integer, intent(out) :: code           !! status code of the solve
        type(discrete_scheme) :: scheme
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report
        type(holosym_status_t) :: local
        real(wp), allocatable :: x(:), jac(:, :), inverse(:, :)
        integer, allocatable :: pivots(:)
        integer :: i, info

        pivot_ratio = 0
        condition = huge(1.0_wp)
        iterations = 0
        call scheme%init(order_m, order_m - 1, order_m + 1, sys%n, sys%m, local)
        if (local%ok()) then
            allocate (x(scheme%nx), jac(scheme%nx, scheme%nx), pivots(scheme%nx))
            call scheme%set_step(sys, q0, p0, h)
            call scheme%constant_guess(x)
            call newton_solve(scheme, x, settings, max(maxval(abs(q0)), maxval(abs(p0))), &
                              report, local)
            iterations = report%iterations
        end if
        if (local%ok()) call scheme%jacobian(x, jac, local)
        code = local%code
        if (.not. local%ok()) return
        do i = 1, size(jac, 1)
            if (maxval(abs(jac(i, :))) > 0) jac(i, :) = jac(i, :) / maxval(abs(jac(i, :)))
        end do
        inverse = reshape([(merge(1.0_wp, 0.0_wp, mod(i, scheme%nx + 1) == 1), &
                            i = 0, scheme%nx**2 - 1)], [scheme%nx, scheme%nx])
        condition = maxval(sum(abs(jac), dim=1))
        call lu_factor(jac, pivots, info, pivot_ratio=pivot_ratio)
        if (info /= 0) then
            condition = huge(1.0_wp)
            return
        end if
        call lu_solve(jac, pivots, inverse)
        condition = condition * maxval(sum(abs(inverse), dim=1))
    end subroutine jacobian_conditioning

    ! ------------------------------------------------------------------ 4. large steps

    !> Study 4: for both paper systems (pendulum, linkage) and M = 1..max_order (N = M - 1,
    !! G = M + 1), the largest h for which (a) the first step from the paper's state
    !! converges and (b) a run over T = 10 completes; found by doubling from h = 1/8 (up to
    !! 64) and bisecting the first failing bracket (relative resolution 2**(-12)). At the
    !! failing h it records the status and whether the failure is clean (code > 0; the state
    !! unchanged for a step, finite and on the manifold for a run).
    !! Codes: HOLOSYM_INVALID_ARGUMENT (max_order < 1).
    subroutine run_large_step_study(max_order, cells, status, progress_unit, max_steps)
        integer, intent(in) :: max_order !! largest M (>= 1)
        type(large_step_cell_t), allocatable, intent(out) :: cells(:) !! 2 * max_order cells
        type(holosym_status_t), intent(out), optional :: status !! invalid arguments
        integer, intent(in), optional :: progress_unit !! progress lines here
        integer, intent(in), optional :: max_steps !! most steps of a run (default: none)
        integer :: i, limit

        if (max_order < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "large-step study needs M >= 1; " &
                // "got " // int_str(max_order))
            return
        end if
        limit = huge(1)
        if (present(max_steps)) limit = max_steps
        allocate (cells(2 * max_order))
        !$omp parallel do schedule(dynamic, 1) private(i)
        do i = size(cells), 1, -1
            if (i <= max_order) then
                call large_step_cell("pendulum", i, cells(i), limit)
            else
                call large_step_cell("linkage", i - max_order, cells(i), limit)
            end if
            !$omp critical (extremes_progress)
            call progress(progress_unit, "large steps: " // cells(i)%system // ", M = " // &
                int_str(cells(i)%order_m) // " done")
            !$omp end critical (extremes_progress)
        end do
        !$omp end parallel do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine run_large_step_study

    !> One cell of the large-step study.
    subroutine large_step_cell(system, order_m, cell, max_steps)
        character(len=*), intent(in) :: system !! a system name
        integer, intent(in) :: order_m         !! M (N = M - 1, G = M + 1)
        type(large_step_cell_t), intent(out) :: cell !! the cell
        integer, intent(in) :: max_steps !! most steps of a run
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: q0(:), p0(:)
        type(holosym_status_t) :: fail_status
        real(wp) :: energy_error
        integer :: steps_done
        logical :: clean, capped
        integer(int64) :: start

        start = clock_now()
        cell%system = system
        cell%order_m = order_m
        cell%order_n = order_m - 1
        cell%gauss_points = order_m + 1
        call make_system(system, sys, q0, p0, fail_status)
        if (.not. fail_status%ok()) then
            cell%step_fail_code = fail_status%code
            cell%step_fail_message = fail_status%message
            return
        end if
        call search_largest_step(sys, q0, p0, order_m, .false., cell%h_step, cell%h_step_fail, &
                                 fail_status, steps_done, clean, capped, max_steps)
        cell%step_fail_code = fail_status%code
        cell%step_fail_message = fail_status%message
        cell%step_fail_clean = clean
        cell%capped = capped
        call search_largest_step(sys, q0, p0, order_m, .true., cell%h_run, cell%h_run_fail, &
                                 fail_status, cell%run_fail_steps, cell%run_fail_clean, capped, &
                                 max_steps)
        cell%run_fail_code = fail_status%code
        cell%capped = cell%capped .or. capped
        if (cell%h_run > 0) then
            call large_step_trial(sys, q0, p0, order_m, .true., cell%h_run, fail_status, &
                                  steps_done, clean, energy_error, max_steps)
            cell%run_energy_error = energy_error
        end if
        cell%seconds = seconds_since(start)
    end subroutine large_step_cell

    !> Largest converging h (0 if none down to the floor) and the failing h just above it,
    !! with the failure's status, steps done and cleanliness.
    subroutine search_largest_step(sys, q0, p0, order_m, run, h_good, h_bad, bad_status, &
                                   bad_steps, bad_clean, hit_cap, max_steps)
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(in) :: q0(:)          !! start coordinates
        real(wp), intent(in) :: p0(:)          !! start momenta
        integer, intent(in) :: order_m         !! M (N = M - 1, G = M + 1)
        logical, intent(in) :: run             !! runs over T = 10, else first steps
        real(wp), intent(out) :: h_good        !! largest h found to succeed (0: none)
        real(wp), intent(out) :: h_bad         !! failing h above it (0: none)
        type(holosym_status_t), intent(out) :: bad_status !! failure at h_bad
        integer, intent(out) :: bad_steps      !! steps done at h_bad
        logical, intent(out) :: bad_clean      !! whether that failure is clean
        logical, intent(out) :: hit_cap        !! h reached the cap of the search
        integer, intent(in) :: max_steps !! most steps of a run
        type(holosym_status_t) :: local
        real(wp) :: h, energy
        integer :: k, done
        logical :: failure_clean

        h_good = 0
        h_bad = 0
        hit_cap = .false.
        bad_clean = .false.
        bad_steps = 0
        bad_status%message = ""
        h = search_start
        call large_step_trial(sys, q0, p0, order_m, run, h, local, done, failure_clean, energy, &
                              max_steps)
        if (local%ok()) then
            h_good = h
            do
                if (h_good >= search_cap) then
                    hit_cap = .true.
                    return
                end if
                h = 2 * h_good
                call large_step_trial(sys, q0, p0, order_m, run, h, local, done, &
                                      failure_clean, energy, max_steps)
                if (.not. local%ok()) exit
                h_good = h
            end do
            h_bad = h
            bad_status = local
            bad_steps = done
            bad_clean = failure_clean
        else
            do while (.not. local%ok())
                h_bad = h
                bad_status = local
                bad_steps = done
                bad_clean = failure_clean
                h = h_bad / 2
                if (h < search_floor) return
                call large_step_trial(sys, q0, p0, order_m, run, h, local, done, &
                                      failure_clean, energy, max_steps)
            end do
            h_good = h
        end if
        do k = 1, bisection_steps
            h = sqrt(h_good * h_bad)
            call large_step_trial(sys, q0, p0, order_m, run, h, local, done, failure_clean, &
                                  energy, max_steps)
            if (local%ok()) then
                h_good = h
            else
                h_bad = h
                bad_status = local
                bad_steps = done
                bad_clean = failure_clean
            end if
        end do
    end subroutine search_largest_step

    !> One first step (run = .false.) or one run over T = 10 at step h, from (q0, p0).
    subroutine large_step_trial(sys, q0, p0, order_m, run, h, local, done, clean_failure, &
                                energy, max_steps)
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(in) :: q0(:)          !! start coordinates
        real(wp), intent(in) :: p0(:)          !! start momenta
        integer, intent(in) :: order_m         !! M (N = M - 1, G = M + 1)
        logical, intent(in) :: run             !! a run over T = 10, else one step
        real(wp), intent(in) :: h              !! step size
        type(holosym_status_t), intent(out) :: local !! outcome
        integer, intent(out) :: done           !! steps done
        logical, intent(out) :: clean_failure  !! a clean failure
        real(wp), intent(out) :: energy        !! max relative energy error of a run
        integer, intent(in) :: max_steps !! most steps of a run
        type(constrained_integrator) :: integrator
        type(run_monitor) :: monitor
        real(wp) :: q(size(q0)), p(size(p0)), position, velocity, scaled_q, scaled_p
        integer :: steps
        q = q0
        p = p0
        done = 0
        energy = 0
        clean_failure = .false.
        call integrator%init(sys, order_m, order_m - 1, order_m + 1, local)
        if (.not. local%ok()) return
        if (run) then
            steps = min(max(1, nint(large_run_span / h)), max_steps)
            call monitor_start(monitor, sys, q, p, steps, growth_block_factor, .false., steps)
            call integrator%integrate(sys, q, p, h, steps, monitor, done, local)
            energy = monitor%energy_max
        else
            call integrator%step(sys, q, p, h, status=local)
        end if
        clean_failure = local%code > 0 .and. all(is_finite(q)) .and. all(is_finite(p))
        if (done == 0) then
            clean_failure = clean_failure .and. all(q == q0) .and. all(p == p0)
        else
            call manifold_residuals(sys, q, p, position, velocity, scaled_q, scaled_p)
            clean_failure = clean_failure .and. scaled_q <= manifold_tolerance_default &
                .and. scaled_p <= manifold_tolerance_default
        end if
    end subroutine large_step_trial

    ! ------------------------------------------------------------------ 5. stiff

    !> Study 5: the spring-linkage with each stiffness k, from the paper's state, for each
    !! M in `orders` (N = M - 1, G = M + 1) and each omega h (omega = sqrt(k / m_r), the
    !! spring frequency of a track): a run over `periods` spring periods.
    !! Codes: HOLOSYM_INVALID_ARGUMENT (empty lists, k <= 0, omega h <= 0, periods <= 0).
    subroutine run_stiff_study(stiffnesses, orders, omega_h, periods, cells, status, &
                               progress_unit, max_steps)
        real(wp), intent(in) :: stiffnesses(:) !! k values (> 0)
        integer, intent(in) :: orders(:)       !! M values (>= 1)
        real(wp), intent(in) :: omega_h(:)     !! omega h values (> 0)
        real(wp), intent(in) :: periods        !! span in spring periods (> 0)
        type(stiff_cell_t), allocatable, intent(out) :: cells(:) !! k, then M, then omega h
        type(holosym_status_t), intent(out), optional :: status !! invalid arguments
        integer, intent(in), optional :: progress_unit !! progress lines here
        integer, intent(in), optional :: max_steps !! most steps of a run (default: none)
        integer :: i, a, b, c, limit

        if (size(stiffnesses) < 1 .or. size(orders) < 1 .or. size(omega_h) < 1 .or. &
            .not. all(stiffnesses > 0) .or. any(orders < 1) .or. .not. all(omega_h > 0) .or. &
            .not. periods > 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "stiff study needs k > 0, " // &
                "M >= 1, omega h > 0 and periods > 0; got periods = " // real_str(periods))
            return
        end if
        limit = huge(1)
        if (present(max_steps)) limit = max_steps
        allocate (cells(size(stiffnesses) * size(orders) * size(omega_h)))
        i = 0
        do a = 1, size(stiffnesses)
            do b = 1, size(orders)
                do c = 1, size(omega_h)
                    i = i + 1
                    cells(i)%stiffness = stiffnesses(a)
                    cells(i)%order_m = orders(b)
                    cells(i)%order_n = orders(b) - 1
                    cells(i)%gauss_points = orders(b) + 1
                    cells(i)%omega_h = omega_h(c)
                end do
            end do
        end do
        !$omp parallel do schedule(dynamic, 1) private(i)
        do i = size(cells), 1, -1
            call stiff_cell(periods, cells(i), limit)
            !$omp critical (extremes_progress)
            call progress(progress_unit, "stiff: k = " // real_str(cells(i)%stiffness) // &
                ", M = " // int_str(cells(i)%order_m) // ", omega h = " // &
                real_str(cells(i)%omega_h) // " done")
            !$omp end critical (extremes_progress)
        end do
        !$omp end parallel do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine run_stiff_study

    !> One run of the stiff study.
    subroutine stiff_cell(periods, cell, max_steps)
        real(wp), intent(in) :: periods           !! spring periods of the run
        type(stiff_cell_t), intent(inout) :: cell !! k, M and omega h in, measurements out
        integer, intent(in) :: max_steps          !! most steps of a run
        type(spring_linkage), target :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: monitor
        type(holosym_status_t) :: local
        real(wp) :: q(6), p(6), omega
        sys = spring_linkage(stiffness=cell%stiffness)
        call sys%initial_state(q, p)
        omega = sqrt(cell%stiffness / sys%track_mass)
        cell%h = cell%omega_h / omega
        cell%steps = min(max(1, nint(periods * 2 * pi() / cell%omega_h)), max_steps)
        call monitor_start(monitor, sys, q, p, cell%steps, growth_block_factor, .false., &
                           cell%steps)
        call integrator%init(sys, cell%order_m, cell%order_n, cell%gauss_points, local)
        if (local%ok()) call integrator%integrate(sys, q, p, cell%h, cell%steps, monitor, &
                                                  cell%steps_done, local)
        cell%code = local%code
        cell%message = local%message
        cell%energy_error = monitor%energy_max
        cell%constraint_max = monitor%constraint_max
        cell%iterations = real(monitor%iterations, wp) / max(monitor%steps, 1)
    end subroutine stiff_cell

    ! ------------------------------------------------------------------ 6. near-singular

    !> Study 6: the linkage with rod length L = 2R(1 + delta), started at rest with ball 1
    !! at the bottom of track 1, ball 2 at the top of track 2 and the rod almost
    !! perpendicular to the springs: x1 = s1 = -e/2, x2 = s2 = e/2, y1 = -R, y2 = R with
    !! e = sqrt(L**2 - 4R**2). At delta = 0 the three constraint gradients are dependent
    !! (Phi has rank 2); the smallest relative pivot of Phi Phi^T is about delta. The
    !! state is projected onto the manifold, then run for `steps` steps of h with (2, 1, 3).
    !! Codes: HOLOSYM_INVALID_ARGUMENT (empty list, delta < 0, steps < 1, h <= 0).
    subroutine run_near_singular_study(deltas, steps, h, cells, status)
        real(wp), intent(in) :: deltas(:) !! relative excess of the rod over 2R (>= 0)
        integer, intent(in) :: steps      !! steps per run (>= 1)
        real(wp), intent(in) :: h         !! step size (> 0)
        type(near_singular_cell_t), allocatable, intent(out) :: cells(:) !! one per delta
        type(holosym_status_t), intent(out), optional :: status !! invalid arguments
        type(spring_linkage), target :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: monitor
        type(holosym_status_t) :: local
        real(wp) :: q(6), p(6), radius, excess, jac(3, 6), gram(3, 3)
        integer :: i, pivots(3), info

        if (size(deltas) < 1 .or. .not. all(deltas >= 0) .or. steps < 1 .or. .not. h > 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "near-singular study needs " // &
                "delta >= 0, steps >= 1 and h > 0; got steps = " // int_str(steps) // &
                ", h = " // real_str(h))
            return
        end if
        allocate (cells(size(deltas)))
        do i = 1, size(deltas)
            cells(i)%delta = deltas(i)
            sys = spring_linkage()
            radius = sys%track_radius
            sys%rod_length = 2 * radius * (1 + deltas(i))
            excess = 2 * radius * sqrt(deltas(i) * (2 + deltas(i)))
            q = [-excess / 2, -radius, excess / 2, radius, -excess / 2, excess / 2]
            p = 0
            call sys%constraint_jacobian(q, jac)
            gram = matmul(jac, transpose(jac))
            call lu_factor(gram, pivots, info, tolerance=0.0_wp, pivot_ratio=cells(i)%gram_pivot)
            call project_to_manifold(sys, q, p, local)
            cells(i)%projection_code = local%code
            call monitor_start(monitor, sys, q, p, steps, growth_block_factor, .false., steps)
            call integrator%init(sys, paper_order_m, paper_order_n, paper_gauss, local)
            if (local%ok()) call integrator%integrate(sys, q, p, h, steps, monitor, &
                                                      cells(i)%steps_done, local)
            cells(i)%code = local%code
            cells(i)%message = local%message
            cells(i)%lambda_max = monitor%lambda_max
            cells(i)%newton_pivot = monitor%pivot_min
            if (monitor%steps == 0) cells(i)%newton_pivot = 0
            cells(i)%constraint_max = monitor%constraint_max
            cells(i)%energy_error = monitor%energy_max
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine run_near_singular_study

end module holosym_study_extremes
