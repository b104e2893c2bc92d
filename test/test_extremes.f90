!> Tests at the extremes, at the library level: the projection onto the constraint
!! manifold, shortened versions of the measurements of `holosym extremes` (long run and
!! round-off growth, tiny steps, high orders, large steps, stiff springs, near-singular
!! constraints), the provably singular family G <= N, and a randomized test of 10,000 valid
!! and invalid parameter sets and states. The `extremes` command itself is tested through
!! the executable in test_extremes_cli.
module test_extremes
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, &
        ieee_negative_inf, ieee_is_finite
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym, only: wp, holosym_status_t, constrained_hamiltonian, constrained_integrator, &
        spherical_pendulum, spring_linkage, planar_pendulum, project_to_manifold, &
        projection_report_t, manifold_residuals, manifold_tolerance_default, step_info_t, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, &
        HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
        HOLOSYM_STEP_TOO_LARGE, HOLOSYM_STEP_TOO_SMALL, HOLOSYM_INVALID_MODEL, &
        HOLOSYM_INCONSISTENT_SYSTEM
    use holosym_status_codes, only: int_str, real_str
    use holosym_study_extremes, only: gauss_rule_error, lobatto_rule_error, basis_error, &
        jacobian_conditioning, run_monitor, monitor_start, search_largest_step, &
        near_singular_cell_t, run_near_singular_study, max_study_order, error_floor
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close, &
        check_status_code, overflow_traps
    implicit none
    private
    public :: extremes_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Bound on the constraint residuals of the runs: 5000 eps (9.6e-31 in real128, within
    !! the required 1e-30; 1.1e-12 in real64).
    real(wp), parameter :: constraint_bound = 5000 * eps
    !> "No drift": the max energy error of the whole run may exceed that of the early
    !! window by at most this factor (the error of a symplectic method is quasi-periodic).
    real(wp), parameter :: drift_factor = 2
    !> Quadrature and basis up to 16 points must be accurate to ~1e-32: 2**10 epsilon.
    real(wp), parameter :: rule_tolerance = 1024 * eps
    !> A measured order agrees with the law 2M within this distance (as the tables command).
    real(wp), parameter :: order_agreement = 0.3_wp
    !> Largest decimal exponent e of the randomized off-manifold offsets 10**(-e): the offset
    !! must stay 1e5 times above the manifold tolerance 1024 eps, about 10**(8 - precision)
    !! (20 in real128, 7 in real64, where 1e-20 would be far below round-off).
    integer, parameter :: max_offset_exponent = min(20, precision(1.0_wp) - 8)
    !> Cases of the randomized test.
    integer, parameter :: random_cases = 10000
    !> Every status code the library documents (holosym_status_codes).
    integer, parameter :: documented_codes(*) = [HOLOSYM_INVALID_ORDER, &
        HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_STEP_SIZE, &
        HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, HOLOSYM_USER_ABORT, &
        HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NONFINITE_VALUE, &
        HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, HOLOSYM_STEP_TOO_LARGE, HOLOSYM_STEP_TOO_SMALL, &
        HOLOSYM_INVALID_MODEL, HOLOSYM_INCONSISTENT_SYSTEM]

    !> Park-Miller minimal standard generator: deterministic on every compiler, no overflow
    !! in 64-bit integers.
    integer(int64), parameter :: rng_modulus = 2147483647_int64
    integer(int64), parameter :: rng_multiplier = 48271_int64

    !> Spherical pendulum with a non-quadratic kinetic energy sum(cosh(p_i)) - sin(z):
    !! the momentum projection needs several Newton iterations.
    type, extends(spherical_pendulum) :: cosh_pendulum
    contains
        procedure :: hamiltonian => cosh_hamiltonian
        procedure :: dh_dp => cosh_dh_dp
    end type cosh_pendulum

    !> H = |p|^2/2; the constraints are left to the extensions.
    type, abstract, extends(constrained_hamiltonian) :: free_particle
    contains
        procedure :: hamiltonian => free_hamiltonian
        procedure :: dh_dq => free_dh_dq
        procedure :: dh_dp => free_dh_dp
    end type free_particle

    !> n = 2, m = 1, phi = atan(q_1) - 1/2, H = |p|^2/2: Newton diverges from |q_1| > 1.4.
    type, extends(free_particle) :: atan_system
    contains
        procedure :: constraint => atan_constraint
        procedure :: constraint_jacobian => atan_constraint_jacobian
    end type atan_system

    !> Settable sizes, H = |p|^2/2, phi_l = q_l (for invalid n, m).
    type, extends(free_particle) :: line_system
    contains
        procedure :: constraint => line_constraint
        procedure :: constraint_jacobian => line_constraint_jacobian
    end type line_system

    !> The sphere constraint stated twice: Phi has rank 1 < m = 2.
    type, extends(spherical_pendulum) :: twice_sphere
    contains
        procedure :: constraint => twice_constraint
        procedure :: constraint_jacobian => twice_constraint_jacobian
        procedure :: constraint_hessian => twice_constraint_hessian
    end type twice_sphere

    !> The pendulum whose dH/dq is NaN everywhere.
    type, extends(spherical_pendulum) :: nan_pendulum
    contains
        procedure :: dh_dq => nan_dh_dq
    end type nan_pendulum

contains

    !> The tests of this suite.
    function extremes_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("projection_pendulum", projection_pendulum), &
            new_test("projection_linkage", projection_linkage), &
            new_test("projection_nonquadratic_momentum", projection_nonquadratic), &
            new_test("projection_bad_inputs", projection_bad_inputs), &
            new_test("projection_numerical_failures", projection_numerical_failures), &
            new_test("singular_family_g_at_most_n", singular_family), &
            new_test("long_run_no_drift", long_run_no_drift), &
            new_test("roundoff_growth_bounded", roundoff_growth), &
            new_test("roundoff_no_drift_either_path", roundoff_no_drift), &
            new_test("tiny_steps_turn_to_roundoff", tiny_steps), &
            new_test("quadrature_and_basis_to_16_points", quadrature_and_basis), &
            new_test("high_orders_and_conditioning", high_orders), &
            new_test("large_steps_fail_cleanly", large_steps), &
            new_test("stiff_springs", stiff_springs), &
            new_test("near_singular_constraints", near_singular), &
            new_test("randomized_10000_cases", randomized_cases) &
            ]
    end function extremes_tests

    ! ------------------------------------------------------------------ test systems

    !> sum(cosh(p)) - mass sin(z).
    function cosh_hamiltonian(self, q, p) result(energy)
        class(cosh_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:) !! coordinates
        real(wp), intent(in) :: p(:) !! momenta
        real(wp) :: energy
        energy = sum(cosh(p)) - self%mass * sin(q(3))
    end function cosh_hamiltonian

    !> sinh(p).
    subroutine cosh_dh_dp(self, q, p, gradient)
        class(cosh_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)         !! coordinates
        real(wp), intent(in) :: p(:)         !! momenta
        real(wp), intent(out) :: gradient(:) !! sinh(p)
        gradient = sinh(p)
    end subroutine cosh_dh_dp

    !> |p|^2/2.
    function free_hamiltonian(self, q, p) result(energy)
        class(free_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:) !! coordinates
        real(wp), intent(in) :: p(:) !! momenta
        real(wp) :: energy
        energy = sum(p**2) / 2
    end function free_hamiltonian

    !> 0.
    subroutine free_dh_dq(self, q, p, gradient)
        class(free_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)         !! coordinates
        real(wp), intent(in) :: p(:)         !! momenta
        real(wp), intent(out) :: gradient(:) !! zero
        gradient = 0
    end subroutine free_dh_dq

    !> p.
    subroutine free_dh_dp(self, q, p, gradient)
        class(free_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)         !! coordinates
        real(wp), intent(in) :: p(:)         !! momenta
        real(wp), intent(out) :: gradient(:) !! p
        gradient = p
    end subroutine free_dh_dp

    !> atan(q_1) - 1/2.
    subroutine atan_constraint(self, q, phi)
        class(atan_system), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)      !! coordinates
        real(wp), intent(out) :: phi(:)   !! atan(q_1) - 1/2
        phi(1) = atan(q(1)) - 0.5_wp
    end subroutine atan_constraint

    !> (1/(1 + q_1^2), 0).
    subroutine atan_constraint_jacobian(self, q, jacobian)
        class(atan_system), intent(in) :: self  !! the system
        real(wp), intent(in) :: q(:)            !! coordinates
        real(wp), intent(out) :: jacobian(:, :) !! (1/(1 + q_1^2), 0)
        jacobian = 0
        jacobian(1, 1) = 1 / (1 + q(1)**2)
    end subroutine atan_constraint_jacobian

    !> phi_l = q_l.
    subroutine line_constraint(self, q, phi)
        class(line_system), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)     !! coordinates
        real(wp), intent(out) :: phi(:)  !! q(1:m)
        phi = q(1:self%m)
    end subroutine line_constraint

    !> [I 0].
    subroutine line_constraint_jacobian(self, q, jacobian)
        class(line_system), intent(in) :: self  !! the system
        real(wp), intent(in) :: q(:)            !! coordinates
        real(wp), intent(out) :: jacobian(:, :) !! [I 0]
        integer :: l
        jacobian = 0
        do l = 1, self%m
            jacobian(l, l) = 1
        end do
    end subroutine line_constraint_jacobian

    !> The sphere constraint twice.
    subroutine twice_constraint(self, q, phi)
        class(twice_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)     !! coordinates
        real(wp), intent(out) :: phi(:)  !! |q|^2 - l^2, twice
        phi = sum(q**2) - self%length**2
    end subroutine twice_constraint

    !> Two equal rows 2q.
    subroutine twice_constraint_jacobian(self, q, jacobian)
        class(twice_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)            !! coordinates
        real(wp), intent(out) :: jacobian(:, :) !! rows 2q, 2q
        jacobian(1, :) = 2 * q
        jacobian(2, :) = 2 * q
    end subroutine twice_constraint_jacobian

    !> Both constraints' second derivatives: 2 I each.
    subroutine twice_constraint_hessian(self, q, hessian)
        class(twice_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)              !! coordinates
        real(wp), intent(out) :: hessian(:, :, :) !! n x n x 2
        integer :: i
        hessian = 0
        do i = 1, size(q)
            hessian(i, i, :) = 2
        end do
    end subroutine twice_constraint_hessian

    !> NaN.
    subroutine nan_dh_dq(self, q, p, gradient)
        class(nan_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)         !! coordinates
        real(wp), intent(in) :: p(:)         !! momenta
        real(wp), intent(out) :: gradient(:) !! NaN
        gradient = ieee_value(1.0_wp, ieee_quiet_nan)
    end subroutine nan_dh_dq

    ! ------------------------------------------------------------------ helpers

    !> True when a and b have the same size and the same bits.
    logical function same_bits(a, b)
        real(wp), intent(in) :: a(:) !! first array
        real(wp), intent(in) :: b(:) !! second array
        same_bits = size(a) == size(b)
        if (same_bits .and. size(a) > 0) same_bits = all(transfer(a, [0_int64]) == &
                                                         transfer(b, [0_int64]))
    end function same_bits

    !> Both scaled residuals of (q, p) at most the integrator's tolerance.
    logical function on_manifold(sys, q, p)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:) !! coordinates
        real(wp), intent(in) :: p(:) !! momenta
        real(wp) :: position, velocity, scaled_position, scaled_velocity
        call manifold_residuals(sys, q, p, position, velocity, scaled_position, scaled_velocity)
        on_manifold = scaled_position <= manifold_tolerance_default .and. &
                      scaled_velocity <= manifold_tolerance_default
    end function on_manifold

    !> Check a failed call: expected code, a message containing `text`, state unchanged.
    subroutine check_failure(error, status, code, text, q, p, q0, p0, label)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        type(holosym_status_t), intent(in) :: status !! returned status
        integer, intent(in) :: code           !! expected code
        character(len=*), intent(in) :: text  !! required part of the message
        real(wp), intent(in) :: q(:), p(:)    !! state after the call
        real(wp), intent(in) :: q0(:), p0(:)  !! state before the call
        character(len=*), intent(in) :: label !! the case
        call check_status_code(error, status%code, code, label)
        if (allocated(error)) return
        call check(error, allocated(status%message), label // ": no message")
        if (allocated(error)) return
        call check(error, index(status%message, text) > 0, label // ": message '" // &
            status%message // "' does not mention '" // text // "'")
        call check(error, same_bits(q, q0) .and. same_bits(p, p0), label // &
            ": the caller's state was changed")
    end subroutine check_failure

    !> Next uniform number in (0, 1) of the Park-Miller generator.
    real(wp) function uniform(state)
        integer(int64), intent(inout) :: state !! generator state in 1 .. modulus - 1
        state = mod(rng_multiplier * state, rng_modulus)
        uniform = real(state, wp) / rng_modulus
    end function uniform

    !> Uniform integer in low..high.
    integer function draw(state, low, high)
        integer(int64), intent(inout) :: state !! generator state
        integer, intent(in) :: low, high       !! range
        draw = low + min(int(uniform(state) * (high - low + 1)), high - low)
    end function draw

    ! ------------------------------------------------------------------ projection

    !> A pendulum state pushed off both constraints comes back: residuals at round-off,
    !! the integrator accepts it, and projecting again changes it by round-off only.
    subroutine projection_pendulum(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(holosym_status_t) :: status
        type(projection_report_t) :: report
        real(wp) :: q(3), p(3), q0(3), p0(3), q1(3), p1(3)
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        q = 1.01_wp * q0 + [0.003_wp, -0.002_wp, 0.001_wp]
        p = p0 + 0.05_wp * q0
        call check(error, .not. on_manifold(sys, q, p), "perturbed state is off the manifold")
        call project_to_manifold(sys, q, p, status, report=report)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "project")
        if (allocated(error)) return
        call check(error, on_manifold(sys, q, p), "projected state is on the manifold")
        call check(error, report%position_after <= 4 * eps .and. &
            report%velocity_after <= 4 * eps, "residuals at round-off: " // &
            real_str(report%position_after) // ", " // real_str(report%velocity_after))
        call check(error, report%position_iterations >= 2 .and. &
            report%momentum_iterations == 1, "iterations " // &
            int_str(report%position_iterations) // ", " // int_str(report%momentum_iterations))
        call check(error, report%position_before > 1.0e-3_wp, "residual before reported")
        call check_close(error, sum(q**2), 1.0_wp, 0.0_wp, 4 * eps, "|q|^2 after projection")
        call check_close(error, dot_product(q, p), 0.0_wp, 0.0_wp, 4 * eps, "q . p after")
        q1 = q
        p1 = p
        call project_to_manifold(sys, q1, p1, status)
        call check(error, status%ok() .and. maxval(abs(q1 - q)) <= 4 * eps .and. &
            maxval(abs(p1 - p)) <= 4 * eps, "projection is idempotent to round-off")
        call integrator%init(sys, 2, 1, 3, status)
        call integrator%step(sys, q, p, 0.125_wp, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "step from projected state")
    end subroutine projection_pendulum

    !> The linkage (three constraints) from a perturbed state: on the manifold afterwards,
    !! moved by about the size of the perturbation.
    subroutine projection_linkage(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage) :: sys
        type(holosym_status_t) :: status
        type(projection_report_t) :: report
        real(wp) :: q(6), p(6), q0(6), p0(6)
        real(wp), parameter :: shift = 1.0e-3_wp
        sys = spring_linkage()
        call sys%initial_state(q0, p0)
        q = q0 + shift * [1.0_wp, -2.0_wp, 0.5_wp, 1.5_wp, -1.0_wp, 2.0_wp]
        p = p0 + [0.01_wp, 0.02_wp, -0.03_wp, 0.01_wp, 0.02_wp, -0.01_wp]
        call project_to_manifold(sys, q, p, status, report=report)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "project linkage")
        call check(error, on_manifold(sys, q, p), "linkage state on the manifold")
        call check(error, report%position_shift <= 10 * shift, "moved by " // &
            real_str(report%position_shift))
    end subroutine projection_linkage

    !> With H = sum cosh(p) the hidden constraint is nonlinear in beta: Newton needs
    !! several iterations and still ends at round-off.
    subroutine projection_nonquadratic(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(cosh_pendulum) :: sys
        type(holosym_status_t) :: status
        type(projection_report_t) :: report
        real(wp) :: q(3), p(3)
        sys%spherical_pendulum = spherical_pendulum()
        call sys%initial_state(q, p)
        p = p + 0.8_wp * q
        call project_to_manifold(sys, q, p, status, report=report)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "project cosh pendulum")
        call check(error, report%momentum_iterations >= 3, "momentum iterations " // &
            int_str(report%momentum_iterations))
        call check(error, on_manifold(sys, q, p), "cosh pendulum on the manifold")
        call check_close(error, dot_product(q, sinh(p)), 0.0_wp, 0.0_wp, 8 * eps, &
            "q . H_p after projection")
    end subroutine projection_nonquadratic

    !> Invalid inputs: documented negative codes, message naming the value, state unchanged.
    subroutine projection_bad_inputs(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(line_system) :: line
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), q0(3), p0(3), short(2)
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        q = q0
        p = p0
        line%n = 2
        line%m = 2
        call project_to_manifold(line, q(1:2), p(1:2), status)
        call check_failure(error, status, HOLOSYM_INVALID_DIMENSION, "m = 2", q(1:2), &
            p(1:2), q0(1:2), p0(1:2), "m = n")
        short = q0(1:2)
        call project_to_manifold(sys, short, p, status)
        call check_failure(error, status, HOLOSYM_SIZE_MISMATCH, "got 2", short, p, &
            q0(1:2), p0, "size(q) = 2")
        q(2) = ieee_value(1.0_wp, ieee_quiet_nan)
        call project_to_manifold(sys, q, p, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "NaN in q")
        call check(error, .not. ieee_is_finite(q(2)) .and. same_bits(p, p0), "NaN case: state")
        q = q0
        call project_to_manifold(sys, q, p, status, tolerance=-1.0_wp)
        call check_failure(error, status, HOLOSYM_INVALID_ARGUMENT, "tolerance", q, p, q0, p0, &
            "tolerance -1")
        call project_to_manifold(sys, q, p, status, tolerance=ieee_value(1.0_wp, &
                                                                          ieee_positive_inf))
        call check_failure(error, status, HOLOSYM_INVALID_ARGUMENT, "Infinity", q, p, q0, &
            p0, "tolerance Inf")
        call project_to_manifold(sys, q, p, status, max_iterations=0)
        call check_failure(error, status, HOLOSYM_INVALID_ARGUMENT, "got 0", q, p, q0, p0, &
            "max_iterations 0")
    end subroutine projection_bad_inputs

    !> Numerical failures: divergence (atan), rank deficiency, non-finite user values,
    !! iteration limit; each leaves the state unchanged.
    subroutine projection_numerical_failures(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(atan_system) :: arc
        type(twice_sphere) :: twice
        type(nan_pendulum) :: bad
        type(cosh_pendulum) :: soft
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), q0(3), p0(3), a(2), b(2), a0(2), b0(2)
        arc%n = 2
        arc%m = 1
        a0 = [10.0_wp, 0.0_wp]
        b0 = [0.0_wp, 1.0_wp]
        a = a0
        b = b0
        call project_to_manifold(arc, a, b, status)
        call check_failure(error, status, HOLOSYM_NEWTON_DIVERGED, "diverged", a, b, a0, b0, &
            "atan from q_1 = 10")
        ! From q_1 = 1 Newton converges to tan(1/2).
        a = [1.0_wp, 0.0_wp]
        call project_to_manifold(arc, a, b, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "atan from q_1 = 1")
        call check_close(error, a(1), tan(0.5_wp), 4 * eps, 0.0_wp, "atan solution")
        twice%spherical_pendulum = spherical_pendulum()
        twice%m = 2
        call twice%initial_state(q0, p0)
        q0 = 1.1_wp * q0
        q = q0
        p = p0
        call project_to_manifold(twice, q, p, status)
        call check_failure(error, status, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, "rank deficient", &
            q, p, q0, p0, "doubled constraint")
        bad%spherical_pendulum = spherical_pendulum()
        call bad%initial_state(q0, p0)
        q = q0
        p = p0
        ! dH/dq is not used by the projection: a NaN there does not matter.
        call project_to_manifold(bad, q, p, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "NaN dH/dq is not used")
        soft%spherical_pendulum = spherical_pendulum()
        call soft%initial_state(q0, p0)
        p0 = p0 + 0.8_wp * q0
        q = q0
        p = p0
        call project_to_manifold(soft, q, p, status, max_iterations=1)
        call check_failure(error, status, HOLOSYM_NEWTON_NOT_CONVERGED, "1 iterations", q, p, &
            q0, p0, "iteration limit 1")
        ! sinh overflows for huge momenta: a non-finite user value. (An overflow on purpose,
        ! in the system's code: left out where overflow traps.)
        if (overflow_traps()) return
        p = p0 + 1.0e5_wp * q0
        p0 = p
        call project_to_manifold(soft, q, p, status)
        call check_failure(error, status, HOLOSYM_NONFINITE_VALUE, "dh_dp", q, p, q0, p0, &
            "sinh overflow")
    end subroutine projection_numerical_failures

    ! ------------------------------------------------------------------ singular family

    !> G <= N: the momentum polynomial (degree N) enters the step equations only through its
    !! values at the G Gauss points, so a nonzero polynomial vanishing there leaves every
    !! equation unchanged: the Newton Jacobian is singular for every system. `init` rejects
    !! it with HOLOSYM_INVALID_ORDER, on all three models.
    subroutine singular_family(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: configs(3, 5) = reshape([1, 1, 1, 2, 2, 1, 2, 2, 2, 3, 3, 2, &
                                                       4, 3, 3], [3, 5])
        type(spherical_pendulum), target :: sphere
        type(spring_linkage), target :: linkage
        type(planar_pendulum), target :: planar
        integer :: i
        sphere = spherical_pendulum()
        linkage = spring_linkage()
        planar = planar_pendulum()
        do i = 1, size(configs, 2)
            call one(sphere, "pendulum")
            call one(linkage, "linkage")
            call one(planar, "planar")
            if (allocated(error)) return
        end do

    contains

        subroutine one(sys, name)
            class(constrained_hamiltonian), intent(in), target :: sys
            character(len=*), intent(in) :: name
            type(constrained_integrator) :: integrator
            type(holosym_status_t) :: status
            type(spherical_pendulum) :: sphere_model
            type(spring_linkage) :: linkage_model
            type(planar_pendulum) :: planar_model
            real(wp), allocatable :: q(:), p(:), q0(:), p0(:)
            character(len=:), allocatable :: label
            allocate (q0(sys%n), p0(sys%n))
            select case (name)
            case ("pendulum")
                call sphere_model%initial_state(q0, p0)
            case ("linkage")
                call linkage_model%initial_state(q0, p0)
            case default
                call planar_model%initial_state(q0, p0)
            end select
            q = q0
            p = p0
            label = name // " (M, N, G) = (" // int_str(configs(1, i)) // ", " // &
                int_str(configs(2, i)) // ", " // int_str(configs(3, i)) // ")"
            call integrator%init(sys, configs(1, i), configs(2, i), configs(3, i), status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ORDER, "init " // label)
            call check(error, index(status%message, "G = " // int_str(configs(3, i))) > 0, &
                "message of " // label // ": " // status%message)
            ! The rejected integrator cannot step, and the state is untouched.
            call integrator%step(sys, q, p, 0.125_wp, status=status)
            call check(error, .not. status%ok() .and. all(q == q0) .and. all(p == p0), &
                "step after a rejected init " // label)
        end subroutine one

    end subroutine singular_family

    ! ------------------------------------------------------------------ studies, shortened

    !> Set up the extremes studies' monitor for a run from (q, p) of `steps` steps, with
    !! L_z recorded after each step when `track_lz`.
    subroutine record_start(record, sys, q, p, steps, window, track_lz)
        type(run_monitor), intent(out) :: record          !! the record
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:), p(:)                !! start state
        integer, intent(in) :: steps                      !! steps of the run
        integer, intent(in) :: window                     !! early window of the drift ratio
        logical, intent(in) :: track_lz                   !! record L_z (spherical pendulum)
        call monitor_start(record, sys, q, p, steps, 2, track_lz, window)
        allocate (record%lz_error(steps))
        record%lz_error = 0
    end subroutine record_start

    !> `steps` steps of (M, M - 1, M + 1) at h through `integrate`: the state at the end
    !! and the record of the run.
    subroutine record_run(sys, q0, p0, order_m, h, steps, q_end, record, status, general)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:), p0(:)   !! start state
        integer, intent(in) :: order_m         !! M
        real(wp), intent(in) :: h              !! step size
        integer, intent(in) :: steps           !! number of steps
        real(wp), intent(out) :: q_end(:)      !! q after the run
        type(run_monitor), intent(out) :: record !! what happened
        type(holosym_status_t), intent(out) :: status !! outcome
        !> The general scheme even where the reduced step applies (references: it keeps the
        !! momenta as unknowns, with |E| ~ M^2 times less round-off than the reduced step).
        logical, intent(in), optional :: general
        type(constrained_integrator) :: integrator
        real(wp) :: q(size(q0)), p(size(p0))
        q = q0
        p = p0
        call record_start(record, sys, q, p, steps, steps, .false.)
        if (present(general)) integrator%structured = .not. general
        call integrator%init(sys, order_m, order_m - 1, order_m + 1, status)
        if (status%ok()) call integrator%integrate(sys, q, p, h, steps, record, status=status)
        q_end = q
    end subroutine record_run

    !> Long run shortened: 1000 steps of the paper's setting (spherical pendulum,
    !! (M, N, G) = (2, 1, 3), h = 1/8): no energy drift and constraints at round-off.
    subroutine long_run_no_drift(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: record
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        integer, parameter :: steps = 1000, window = 100
        integer :: done
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call record_start(record, sys, q, p, steps, window, .true.)
        call integrator%init(sys, 2, 1, 3, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "init")
        if (allocated(error)) return
        call integrator%integrate(sys, q, p, 0.125_wp, steps, record, done, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "long run")
        call check(error, done == steps, "steps done " // int_str(done))
        if (allocated(error)) return
        call check(error, record%energy_max <= drift_factor * record%energy_window, &
            "energy drift: max over the run " // real_str(record%energy_max) // &
            " > 2 x max over the first 100 steps " // real_str(record%energy_window))
        call check(error, record%constraint_max <= constraint_bound .and. &
            record%velocity_max <= constraint_bound, "constraint residuals " // &
            real_str(record%constraint_max) // ", " // real_str(record%velocity_max))
        call check(error, record%energy_window > 0, "energy error measured")
    end subroutine long_run_no_drift

    !> Round-off growth shortened: L_z = x p_y - y p_x, which the scheme conserves exactly,
    !! changes by round-off only, within the random-walk envelope eps sqrt(k) in every
    !! doubling block of steps (RMS over the block and over two copies of the start state
    !! rotated about z), with compensated (`integrate`) and naive (a loop of `step`)
    !! summation on the default path, and with `integrate` on the general path.
    subroutine roundoff_growth(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: steps = 128, copies = 2
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: record
        type(step_info_t) :: info
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q(3), p(3)
        real(wp) :: sum_squares(3, steps), rms, centre
        integer :: c, variant, k, first, last
        logical :: halt
        real(wp), parameter :: pi = 4 * atan(1.0_wp)

        sys = spherical_pendulum()
        sum_squares = 0
        do c = 1, copies
            call rotated_start(sys, 2 * pi * (c - 1) / copies, q0, p0, error)
            do variant = 1, 3
                q = q0
                p = p0
                call record_start(record, sys, q, p, steps, steps, .true.)
                integrator%structured = variant /= 3
                call integrator%init(sys, 2, 1, 3, status)
                if (variant /= 2) then
                    call integrator%integrate(sys, q, p, 0.125_wp, steps, record, &
                                              status=status)
                else
                    halt = .false.
                    do k = 1, steps
                        call integrator%step(sys, q, p, 0.125_wp, info, status)
                        if (.not. status%ok()) exit
                        call record%observe(k, k * 0.125_wp, q, p, info, halt)
                    end do
                end if
                call check_status_code(error, status%code, HOLOSYM_SUCCESS, "run")
                if (allocated(error)) return
                sum_squares(variant, :) = sum_squares(variant, :) + record%lz_error**2
            end do
        end do
        ! Blocks 1-2, 3-4, 5-8, ..., 65-128.
        first = 1
        last = 2
        do while (first <= steps)
            centre = (real(first, wp) + last) / 2
            do variant = 1, 3
                rms = sqrt(sum(sum_squares(variant, first:last)) / (copies * (last - first + 1)))
                call check(error, rms <= eps * sqrt(centre), "L_z error above eps sqrt(k) in " &
                    // "steps " // int_str(first) // "-" // int_str(last) // ", " // &
                    trim(variant_names(variant)) // ": " // real_str(rms))
            end do
            first = last + 1
            last = 2 * last
        end do
        call check(error, any(sum_squares(1, steps / 2:) > 0), "L_z change measured")

    contains

        !> The runs compared.
        pure function variant_names(variant) result(name)
            integer, intent(in) :: variant
            character(len=32) :: name
            select case (variant)
            case (1)
                name = "compensated summation"
            case (2)
                name = "naive summation"
            case default
                name = "general path"
            end select
        end function variant_names
    end subroutine roundoff_growth

    !> No drift of a conserved quantity on either path: L_z of the spherical pendulum over
    !! 2048 steps of (2, 1, 3) at h = 1/8 with `integrate`, RMS over four copies of the
    !! start state rotated about z, on the reduced and the general path: within 0.08 eps
    !! sqrt(k) over the last half. A drift of a few thousandths of eps per step (an
    !! equation that is not exactly that of the discrete action: 0.13 when the reduced
    !! step took its D_0 row from the rounded tables) exceeds it; the random walk of both
    !! paths stays near 0.04.
    subroutine roundoff_no_drift(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: steps = 2048, copies = 4
        real(wp), parameter :: bound = 0.08_wp
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: record
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q(3), p(3), sum_squares(2), rms
        integer :: c, path
        real(wp), parameter :: pi = 4 * atan(1.0_wp)

        sys = spherical_pendulum()
        sum_squares = 0
        do c = 1, copies
            call rotated_start(sys, 2 * pi * (c - 1) / copies + 0.3_wp, q0, p0, error)
            do path = 1, 2
                q = q0
                p = p0
                call record_start(record, sys, q, p, steps, steps, .true.)
                integrator%structured = path == 1
                call integrator%init(sys, 2, 1, 3, status)
                call integrator%integrate(sys, q, p, 0.125_wp, steps, record, status=status)
                call check_status_code(error, status%code, HOLOSYM_SUCCESS, "run")
                if (allocated(error)) return
                sum_squares(path) = sum_squares(path) + sum(record%lz_error(steps / 2 + 1:)**2)
            end do
        end do
        do path = 1, 2
            rms = sqrt(sum_squares(path) / (copies * (steps / 2)))
            call check(error, rms <= bound * eps * sqrt(0.75_wp * steps), "L_z drifts on " // &
                trim(merge("the reduced path", "the general path", path == 1)) // ": RMS " // &
                real_str(rms) // " in steps " // int_str(steps / 2 + 1) // "-" // &
                int_str(steps) // ", " // real_str(rms / (eps * sqrt(0.75_wp * steps))) // &
                " eps sqrt(k) (bound " // real_str(bound) // ")")
        end do
    end subroutine roundoff_no_drift

    !> The paper's pendulum state rotated by `angle` about the z axis, projected onto the
    !! manifold (checked).
    subroutine rotated_start(sys, angle, q0, p0, error)
        type(spherical_pendulum), intent(in) :: sys
        real(wp), intent(in) :: angle
        real(wp), intent(out) :: q0(3), p0(3)
        type(test_error_t), allocatable, intent(inout) :: error
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        call sys%initial_state(q, p)
        q0 = [cos(angle) * q(1) - sin(angle) * q(2), sin(angle) * q(1) + cos(angle) * q(2), q(3)]
        p0 = [cos(angle) * p(1) - sin(angle) * p(2), sin(angle) * p(1) + cos(angle) * p(2), p(3)]
        call project_to_manifold(sys, q0, p0, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "projection")
    end subroutine rotated_start

    !> Tiny steps shortened: with M = 4 the error after 20 steps falls with h until the
    !! round-off band 64 eps sqrt(K): above it at h_large, inside it at h = 1e-4 (global
    !! error against an M = 8 run with steps of at most 1/8, checked against half of them).
    subroutine tiny_steps(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: steps = 20
        !> Largest step of the study, where M = 4 must be truncation-dominated: 1e-2 in
        !! real128; in real64 even h = 1e-1 is at round-off (1.1e-16), so it uses 0.5.
        real(wp), parameter :: h_large = merge(1.0e-2_wp, 0.5_wp, precision(1.0_wp) >= 30)
        real(wp), parameter :: step_sizes(3) = [h_large, 1.0e-3_wp, 1.0e-4_wp]
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: record
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q(3), p(3), q_ref(3), q_check(3), q_end(3), span, band
        real(wp) :: global_error(3), energy_error(3), reference_change
        integer :: i, reference_steps

        band = 64 * eps * sqrt(real(steps, wp))
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        reference_change = 0
        do i = 1, size(step_sizes)
            span = steps * step_sizes(i)
            reference_steps = max(1, ceiling(span / 0.125_wp))
            call record_run(sys, q0, p0, 8, span / reference_steps, reference_steps, q_ref, &
                            record, status, general=.true.)
            if (status%ok()) call record_run(sys, q0, p0, 8, span / (2 * reference_steps), &
                2 * reference_steps, q_check, record, status, general=.true.)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "reference")
            reference_change = max(reference_change, maxval(abs(q_check - q_ref)))
            call record_run(sys, q0, p0, 4, step_sizes(i), steps, q_end, record, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "tiny run h = " // &
                real_str(step_sizes(i)))
            if (allocated(error)) return
            global_error(i) = maxval(abs(q_end - q_check))
            energy_error(i) = record%energy_max
        end do
        call check(error, global_error(1) > band .and. energy_error(1) > band, &
            "largest h is truncation-dominated: " // real_str(global_error(1)))
        call check(error, global_error(3) <= band .and. energy_error(3) <= band, &
            "h = 1e-4 is at round-off: " // real_str(global_error(3)) // ", " // &
            real_str(energy_error(3)))
        call check(error, global_error(2) < global_error(1), "error decreases with h")
        call check(error, reference_change <= band, "reference accurate: " // &
            real_str(reference_change))
        ! A step size <= 0 is refused by the integrator, the state untouched.
        q = q0
        p = p0
        call integrator%init(sys, 4, 3, 5, status)
        call integrator%integrate(sys, q, p, -1.0_wp, steps, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_STEP_SIZE, "h = -1")
        call check(error, same_bits(q, q0) .and. same_bits(p, p0), "h = -1: state unchanged")
    end subroutine tiny_steps

    !> The rules of the high-order range: Gauss-Legendre with 1..16 points (exact up to
    !! degree 2G - 1), Lobatto with 2..16 points (up to 2K - 3) and the Lagrange basis on the
    !! M + 1 Lobatto nodes for M = 1..15 (tau^k and k tau^(k-1), k <= M, at the Gauss
    !! points) are exact on polynomials to ~1e-32.
    subroutine quadrature_and_basis(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k
        do k = 1, max_study_order + 1
            call check(error, gauss_rule_error(k) <= rule_tolerance, "Gauss " // int_str(k) // &
                " points: " // real_str(gauss_rule_error(k)))
            if (k >= 2) call check(error, lobatto_rule_error(k) <= rule_tolerance, &
                "Lobatto " // int_str(k) // " points: " // real_str(lobatto_rule_error(k)))
            if (k <= max_study_order) call check(error, basis_error(k) <= rule_tolerance, &
                "basis M = " // int_str(k) // ": " // real_str(basis_error(k)))
            if (allocated(error)) return
        end do
    end subroutine quadrature_and_basis

    !> High orders shortened: orders 2M of the energy error for M = 1..3 (pendulum, T = 1,
    !! a pair of step sizes), and the first step's Newton Jacobian is well conditioned
    !! with a conditioning that worsens with M.
    subroutine high_orders(error)
        type(test_error_t), allocatable, intent(out) :: error
        !> Step pair of the order measurement: 1/4, 1/8 in real128; in real64 the M = 3 errors
        !! there sink to round-off, so it uses 1/2, 1/4.
        real(wp), parameter :: h_pair(2) = merge([0.25_wp, 0.125_wp], [0.5_wp, 0.25_wp], &
            precision(1.0_wp) >= 30)
        type(spherical_pendulum), target :: sys
        type(run_monitor) :: record
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q_end(3), energy_error(2), order
        real(wp) :: pivot(3), condition(3)
        integer :: order_m, k, iterations
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        do order_m = 1, 3
            do k = 1, 2
                call record_run(sys, q0, p0, order_m, h_pair(k), nint(1 / h_pair(k)), q_end, &
                                record, status)
                call check_status_code(error, status%code, HOLOSYM_SUCCESS, "run M = " // &
                    int_str(order_m))
                energy_error(k) = record%energy_max
            end do
            if (allocated(error)) return
            call check(error, all(energy_error > error_floor), "order measured, M = " // &
                int_str(order_m))
            if (allocated(error)) return
            order = log(energy_error(1) / energy_error(2)) / log(h_pair(1) / h_pair(2))
            call check(error, abs(order - 2 * order_m) <= order_agreement, "order of M = " // &
                int_str(order_m) // ": " // real_str(order))
            call jacobian_conditioning(sys, q0, p0, order_m, 0.125_wp, pivot(order_m), &
                                       condition(order_m), iterations, status%code)
            call check(error, status%ok() .and. condition(order_m) >= 1 .and. &
                condition(order_m) < 1 / eps, "condition of M = " // int_str(order_m) // &
                ": " // real_str(condition(order_m)))
            if (order_m > 1) call check(error, pivot(order_m) < pivot(order_m - 1) .and. &
                condition(order_m) > condition(order_m - 1), "conditioning worsens with M")
        end do
    end subroutine high_orders

    !> Large steps shortened (M = 1, pendulum and linkage): beyond the largest step Newton
    !! fails with a positive code, the state unchanged (a step) or finite and on the
    !! manifold (a run); never a NaN state. A run's largest step is at most a step's.
    subroutine large_steps(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        sphere = spherical_pendulum()
        linkage = spring_linkage()
        call one(sphere, "pendulum")
        call one(linkage, "linkage")

    contains

        subroutine one(sys, name)
            class(constrained_hamiltonian), intent(in) :: sys
            character(len=*), intent(in) :: name
            real(wp), allocatable :: q0(:), p0(:)
            real(wp) :: h_step, h_step_fail, h_run, h_run_fail
            type(holosym_status_t) :: step_failure, run_failure
            logical :: step_clean, run_clean, capped
            integer :: steps_done
            type(spherical_pendulum) :: sphere_model
            type(spring_linkage) :: linkage_model
            if (allocated(error)) return
            allocate (q0(sys%n), p0(sys%n))
            if (name == "pendulum") then
                call sphere_model%initial_state(q0, p0)
            else
                call linkage_model%initial_state(q0, p0)
            end if
            call search_largest_step(sys, q0, p0, 1, .false., h_step, h_step_fail, &
                                     step_failure, steps_done, step_clean, capped, huge(1))
            call check(error, h_step > 0.125_wp .and. h_step_fail > h_step, name // &
                ": h range " // real_str(h_step) // " .. " // real_str(h_step_fail))
            if (allocated(error)) return
            call check(error, step_failure%code > 0 .and. step_clean, name // &
                ": first-step failure not clean, code " // int_str(step_failure%code))
            call check(error, index(step_failure%message, "h = ") > 0, name // &
                ": message names h: " // step_failure%message)
            call search_largest_step(sys, q0, p0, 1, .true., h_run, h_run_fail, run_failure, &
                                     steps_done, run_clean, capped, huge(1))
            call check(error, h_run_fail > 0 .and. run_failure%code > 0 .and. run_clean, &
                name // ": run failure not clean, code " // int_str(run_failure%code))
            call check(error, h_run > 0 .and. h_run <= h_step * (1 + 1.0e-3_wp), name // &
                ": h_run " // real_str(h_run) // ", h_step " // real_str(h_step))
        end subroutine one

    end subroutine large_steps

    !> Stiff springs shortened: the spring-linkage with k = 10^4 over one spring period at
    !! omega h = 1 and 1/4 (omega = sqrt(k / m_r)): constraints at round-off, and the
    !! smaller step has the smaller energy error.
    subroutine stiff_springs(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp), parameter :: omega_h(2) = [1.0_wp, 0.25_wp], pi = 4 * atan(1.0_wp)
        type(spring_linkage) :: sys
        type(constrained_integrator) :: integrator
        type(run_monitor) :: record
        type(holosym_status_t) :: status
        real(wp) :: q(6), p(6), omega, h(2), energy_error(2)
        integer :: i, steps
        do i = 1, 2
            sys = spring_linkage(stiffness=1.0e4_wp)
            call sys%initial_state(q, p)
            omega = sqrt(1.0e4_wp / sys%track_mass)
            h(i) = omega_h(i) / omega
            steps = max(1, nint(2 * pi / omega_h(i)))
            call record_start(record, sys, q, p, steps, steps, .false.)
            call integrator%init(sys, 2, 1, 3, status)
            if (status%ok()) call integrator%integrate(sys, q, p, h(i), steps, record, &
                                                      status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "stiff run, omega h = " &
                // real_str(omega_h(i)))
            call check(error, record%constraint_max <= constraint_bound, "stiff constraints: " &
                // real_str(record%constraint_max))
            energy_error(i) = record%energy_max
        end do
        call check(error, energy_error(2) < energy_error(1), "energy error falls with h: " // &
            real_str(energy_error(1)) // " -> " // real_str(energy_error(2)))
        call check(error, abs(h(1) - 0.01_wp) <= 4 * eps, "h = omega h / omega")
    end subroutine stiff_springs

    !> Near-singular constraints shortened: the linkage with rod L = 2R(1 + delta), started
    !! at rest next to the configuration where the three constraint gradients become
    !! dependent. Nearly dependent ones still run with residuals at round-off (a smaller
    !! pivot of Phi Phi^T, larger multipliers); dependent ones (delta = 0) give
    !! HOLOSYM_RANK_DEFICIENT_CONSTRAINTS before any step.
    subroutine near_singular(error)
        type(test_error_t), allocatable, intent(out) :: error
        !> The nearly dependent case: 1e-8 in real128; the Gram pivot ~delta**2 must stay
        !! well above n eps, so real64 uses eps**(1/4) = 1.2e-4.
        real(wp), parameter :: delta_near = max(1.0e-8_wp, eps**0.25_wp)
        real(wp), parameter :: deltas(3) = [1.0e-2_wp, delta_near, 0.0_wp]
        type(near_singular_cell_t), allocatable :: cells(:)
        call run_near_singular_study(deltas, 2, 1.0_wp / 64, cells)
        call check(error, all(cells(1:2)%code == HOLOSYM_SUCCESS), "delta > 0 runs")
        call check(error, all(cells(1:2)%constraint_max <= constraint_bound), &
            "near-singular constraints at round-off")
        call check(error, cells(2)%gram_pivot < cells(1)%gram_pivot .and. &
            cells(2)%lambda_max > cells(1)%lambda_max, "pivot falls and lambda grows")
        call check_status_code(error, cells(3)%code, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
            "delta = 0")
        call check(error, index(cells(3)%message, "rank deficient") > 0, "message: " // &
            cells(3)%message)
        call check(error, cells(3)%steps_done == 0, "no step at delta = 0")
    end subroutine near_singular

    ! ------------------------------------------------------------------ randomized

    !> 10,000 random parameter sets and states, valid and invalid (one injected fault, now
    !! and then two): no crash; every result is either a success with the constraints at
    !! round-off (and for runs, every step done) or a documented code with a message, the
    !! caller's state unchanged when no step was done and finite and on the manifold (the
    !! last good step's) otherwise. Single faults must give their specific code.
    subroutine randomized_cases(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer(int64) :: state
        integer :: c, successes, failures
        state = 20260422_int64
        successes = 0
        failures = 0
        do c = 1, random_cases
            call random_case(state, error, successes, failures)
            if (allocated(error)) then
                error%message = "case " // int_str(c) // ": " // error%message
                return
            end if
        end do
        call check(error, successes >= random_cases / 5 .and. failures >= random_cases / 5, &
            "mix of outcomes: " // int_str(successes) // " successes, " // int_str(failures) &
            // " failures")
    end subroutine randomized_cases

    !> One random case.
    subroutine random_case(state, error, successes, failures)
        integer(int64), intent(inout) :: state
        type(test_error_t), allocatable, intent(inout) :: error
        integer, intent(inout) :: successes, failures
        ! Faults (0 = none).
        integer, parameter :: no_fault = 0, bad_m = 1, bad_n = 2, bad_g = 3, g_at_most_n = 4, &
            bad_dimension = 5, bad_size = 6, bad_step = 7, bad_count = 8, off_manifold = 9, &
            nonfinite_state = 10, user_nan = 11, rank_deficient = 12, huge_step = 13, &
            fault_count = 13
        ! Modes.
        integer, parameter :: mode_step = 1, mode_integrate = 2, mode_project = 3
        class(constrained_hamiltonian), allocatable :: sys
        type(constrained_integrator) :: integrator
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:), q0(:), p0(:)
        real(wp) :: h
        integer :: faults(2), nfaults, mode, order_m, order_n, gauss, steps, done, expected
        integer :: kind, f
        character(len=:), allocatable :: label

        nfaults = 0
        faults = no_fault
        if (uniform(state) < 0.6_wp) then
            nfaults = 1
            faults(1) = draw(state, 1, fault_count)
            if (uniform(state) < 0.15_wp) then
                nfaults = 2
                faults(2) = draw(state, 1, fault_count)
            end if
        end if
        mode = draw(state, mode_step, mode_project)
        kind = draw(state, 1, 3)
        if (any(faults == user_nan)) kind = 4
        if (any(faults == rank_deficient)) kind = 5
        if (any(faults == bad_dimension)) kind = 6
        call random_system(state, kind, sys, q, p, error)
        if (allocated(error)) return
        order_m = draw(state, 1, 2)
        order_n = draw(state, order_m - 1, order_m)
        gauss = draw(state, max(order_m, order_n), max(order_m, order_n) + 1)
        gauss = max(gauss, order_n + 1)
        h = 2.0_wp**(-draw(state, 2, 5)) * (1 + uniform(state) / 2)
        steps = draw(state, 0, 2)
        do f = 1, nfaults
            select case (faults(f))
            case (bad_m)
                order_m = draw(state, -3, 0)
            case (bad_n)
                order_n = draw(state, -3, -1)
            case (bad_g)
                gauss = draw(state, -3, 0)
            case (g_at_most_n)
                order_n = draw(state, 1, 3)
                order_m = draw(state, max(1, order_n - 1), order_n + 1)
                gauss = draw(state, 1, order_n)
            case (bad_size)
                q = [q, 0.5_wp]
                if (uniform(state) < 0.5_wp) p = p(2:)
            case (bad_step)
                select case (draw(state, 1, 5))
                case (1)
                    h = 0
                case (2)
                    h = -h
                case (3)
                    h = ieee_value(1.0_wp, ieee_quiet_nan)
                case (4)
                    h = ieee_value(1.0_wp, ieee_positive_inf)
                case default
                    h = ieee_value(1.0_wp, ieee_negative_inf)
                end select
            case (bad_count)
                steps = draw(state, -5, -1)
            case (off_manifold)
                if (uniform(state) < 0.5_wp .or. size(p) /= size(q)) then
                    q = q * (1 + 10.0_wp**(-draw(state, 2, max_offset_exponent)))
                else
                    p = p + 10.0_wp**(-draw(state, 2, max_offset_exponent)) * q
                end if
            case (nonfinite_state)
                if (size(q) == 0 .or. size(p) == 0) then
                    q = [q, ieee_value(1.0_wp, ieee_quiet_nan)]
                else if (uniform(state) < 0.5_wp) then
                    q(draw(state, 1, size(q))) = ieee_value(1.0_wp, ieee_quiet_nan)
                else
                    p(draw(state, 1, size(p))) = ieee_value(1.0_wp, ieee_positive_inf)
                end if
            case (huge_step)
                h = 10.0_wp**draw(state, 2, 30)
            end select
        end do
        q0 = q
        p0 = p
        label = "faults " // int_str(faults(1)) // "," // int_str(faults(2)) // " mode " // &
            int_str(mode) // " system " // int_str(kind) // " (M, N, G) = (" // &
            int_str(order_m) // ", " // int_str(order_n) // ", " // int_str(gauss) // &
            ") h = " // real_str(h) // " steps " // int_str(steps)

        ! The expected code of a single fault, when it is determined (-huge: any).
        expected = -huge(1)
        if (nfaults == 0) expected = HOLOSYM_SUCCESS
        if (nfaults == 1) then
            select case (faults(1))
            case (bad_m, bad_n, bad_g)
                if (mode /= mode_project) expected = HOLOSYM_INVALID_ORDER
                if (mode == mode_project) expected = HOLOSYM_SUCCESS
            case (bad_dimension)
                expected = HOLOSYM_INVALID_DIMENSION
            case (bad_size)
                expected = HOLOSYM_SIZE_MISMATCH
            case (bad_step)
                if (mode /= mode_project) expected = HOLOSYM_INVALID_STEP_SIZE
                if (mode == mode_project) expected = HOLOSYM_SUCCESS
            case (bad_count)
                if (mode == mode_integrate) expected = HOLOSYM_INVALID_STEP_COUNT
                if (mode /= mode_integrate) expected = HOLOSYM_SUCCESS
            case (off_manifold)
                if (mode /= mode_project) expected = HOLOSYM_OFF_MANIFOLD
                if (mode == mode_project) expected = HOLOSYM_SUCCESS
            case (nonfinite_state)
                expected = HOLOSYM_INVALID_ARGUMENT
            case (g_at_most_n)
                ! Singular for every system, so rejected by init (projection ignores it).
                if (mode /= mode_project) expected = HOLOSYM_INVALID_ORDER
                if (mode == mode_project) expected = HOLOSYM_SUCCESS
            case (user_nan)
                if (mode == mode_step .or. (mode == mode_integrate .and. steps > 0)) &
                    expected = HOLOSYM_NONFINITE_VALUE
                if (mode == mode_project .or. (mode == mode_integrate .and. steps == 0)) &
                    expected = HOLOSYM_SUCCESS
            case (rank_deficient)
                if (mode /= mode_project) expected = HOLOSYM_RANK_DEFICIENT_CONSTRAINTS
                if (mode == mode_project) expected = HOLOSYM_SUCCESS
            end select
        end if

        done = 0
        if (mode == mode_project) then
            call project_to_manifold(sys, q, p, status)
        else
            call integrator%init(sys, order_m, order_n, gauss, status)
            if (status%ok()) then
                if (mode == mode_step) then
                    call integrator%step(sys, q, p, h, status=status)
                    if (status%ok()) done = 1
                else
                    call integrator%integrate(sys, q, p, h, steps, steps_done=done, &
                                              status=status)
                end if
            end if
        end if

        if (status%ok()) then
            successes = successes + 1
            call check(error, all(ieee_is_finite(q)) .and. all(ieee_is_finite(p)), label // &
                ": success with a non-finite state")
            call check(error, on_manifold(sys, q, p), label // ": success off the manifold")
            if (mode == mode_integrate) call check(error, done == steps, label // &
                ": success after " // int_str(done) // " steps")
        else
            failures = failures + 1
            call check(error, any(documented_codes == status%code), label // &
                ": undocumented code " // int_str(status%code))
            call check(error, allocated(status%message), label // ": no message")
            if (allocated(error)) return
            call check(error, len_trim(status%message) > 0, label // ": empty message")
            if (done == 0) then
                call check(error, same_bits(q, q0) .and. same_bits(p, p0), label // &
                    ": failed call changed the state (" // status%message // ")")
            else
                call check(error, all(ieee_is_finite(q)) .and. all(ieee_is_finite(p)) .and. &
                    on_manifold(sys, q, p), label // ": state after " // int_str(done) // &
                    " good steps is not a good state")
            end if
        end if
        if (expected /= -huge(1) .and. .not. allocated(error)) then
            if (expected == HOLOSYM_SUCCESS .and. .not. status%ok()) then
                ! A valid case may still fail numerically (e.g. M >= N + 2 on the pendulum).
                call check(error, status%code > 0, label // ": valid input rejected: " // &
                    status%message)
            else if (expected /= HOLOSYM_SUCCESS) then
                call check_status_code(error, status%code, expected, label // " (" // &
                    status%message // ")")
            end if
        end if
    end subroutine random_case

    !> A random system and a state on its manifold: 1 pendulum, 2 linkage, 3 planar,
    !! 4 NaN dH/dq pendulum, 5 doubled sphere constraint, 6 invalid sizes (n, m).
    subroutine random_system(state, kind, sys, q, p, error)
        integer(int64), intent(inout) :: state
        integer, intent(in) :: kind
        class(constrained_hamiltonian), allocatable, intent(out) :: sys
        real(wp), allocatable, intent(out) :: q(:), p(:)
        type(test_error_t), allocatable, intent(inout) :: error
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        type(planar_pendulum) :: planar
        type(nan_pendulum) :: nan_sphere
        type(twice_sphere) :: twice
        type(line_system) :: line
        type(holosym_status_t) :: status
        real(wp) :: angle, u(3)
        integer :: i
        select case (kind)
        case (1, 4, 5)
            do i = 1, 3
                u(i) = 2 * uniform(state) - 1
            end do
            if (sum(u**2) <= 0) u = [0.0_wp, 0.0_wp, 1.0_wp]
            q = u / sqrt(sum(u**2))
            p = [(2 * uniform(state) - 1, i = 1, 3)]
            p = p - dot_product(p, q) * q
            sphere = spherical_pendulum()
            if (kind == 1) then
                allocate (sys, source=sphere)
            else if (kind == 4) then
                nan_sphere%spherical_pendulum = sphere
                allocate (sys, source=nan_sphere)
            else
                twice%spherical_pendulum = sphere
                twice%m = 2
                allocate (sys, source=twice)
                return
            end if
        case (2)
            linkage = spring_linkage()
            allocate (q(6), p(6))
            call linkage%initial_state(q, p)
            q = q + [(1.0e-2_wp * (2 * uniform(state) - 1), i = 1, 6)]
            p = p + [(0.1_wp * (2 * uniform(state) - 1), i = 1, 6)]
            allocate (sys, source=linkage)
        case (3)
            planar = planar_pendulum()
            angle = 2 * acos(-1.0_wp) * uniform(state)
            q = [sin(angle), -cos(angle)]
            p = (2 * uniform(state) - 1) * [cos(angle), sin(angle)]
            allocate (sys, source=planar)
        case default
            line%n = draw(state, -1, 3)
            line%m = draw(state, -1, 4)
            if (line%n >= 1 .and. line%m >= 0 .and. line%m < line%n) line%m = line%n
            allocate (q(max(line%n, 0)), p(max(line%n, 0)))
            q = 0
            p = 0
            allocate (sys, source=line)
            return
        end select
        call project_to_manifold(sys, q, p, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "random start state")
    end subroutine random_system

end module test_extremes
