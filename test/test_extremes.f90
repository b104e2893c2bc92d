!> Tests of the stability studies: the projection onto the constraint manifold, shortened
!! versions of the six studies of `holosym extremes` (long run and round-off growth, tiny
!! steps, high orders, large steps, stiff springs, near-singular constraints), the provably singular
!! family G <= N, the `extremes` command's options, and a randomized test of 10,000 valid
!! and invalid parameter sets and states.
module test_extremes
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, &
        ieee_negative_inf, ieee_is_finite
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym, only: wp, holosym_status_t, constrained_hamiltonian, constrained_integrator, &
        spherical_pendulum, spring_linkage, planar_pendulum, project_to_manifold, &
        projection_report_t, manifold_residuals, manifold_tolerance_default, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, &
        HOLOSYM_USER_ABORT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS
    use holosym_status, only: int_str, real_str
    use holosym_extremes, only: long_run_result_t, run_long_study, growth_result_t, &
        run_growth_study, tiny_cell_t, run_tiny_study, high_order_row_t, run_high_order_study, &
        large_step_cell_t, run_large_step_study, stiff_cell_t, run_stiff_study, &
        near_singular_cell_t, run_near_singular_study, gauss_rule_error, lobatto_rule_error, &
        basis_error, fitted_exponent, max_study_order, extremes_settings_t, extremes_settings
    use holosym_cli_common, only: cli_argument_t, split_words, EXIT_OK, EXIT_USAGE
    use holosym_cli_extremes, only: extremes_options_t, parse_extremes_options, &
        extremes_command
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close, &
        check_status_code
    implicit none
    private
    public :: extremes_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Bound on the constraint residual of the long run: 5000 eps (9.6e-31 in real128,
    !! 1.1e-12 in real64).
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
    !> Every status code the library documents (holosym_status).
    integer, parameter :: documented_codes(*) = [HOLOSYM_INVALID_ORDER, &
        HOLOSYM_INVALID_DIMENSION, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_STEP_SIZE, &
        HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_OFF_MANIFOLD, HOLOSYM_USER_ABORT, &
        HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, HOLOSYM_NONFINITE_VALUE, &
        HOLOSYM_RANK_DEFICIENT_CONSTRAINTS]

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
            new_test("tiny_steps_turn_to_roundoff", tiny_steps), &
            new_test("quadrature_and_basis_to_16_points", quadrature_and_basis), &
            new_test("high_orders_and_conditioning", high_orders), &
            new_test("large_steps_fail_cleanly", large_steps), &
            new_test("stiff_springs", stiff_springs), &
            new_test("near_singular_constraints", near_singular), &
            new_test("cli_options", cli_options), &
            new_test("cli_in_process", cli_in_process), &
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
        ! sinh overflows for huge momenta: a non-finite user value.
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

    !> Study 1 shortened: no energy drift and constraints at round-off throughout.
    subroutine long_run_no_drift(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(long_run_result_t) :: result
        type(holosym_status_t) :: status
        integer, parameter :: steps = 1000, window = 100
        call run_long_study(steps, window, result, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "long study")
        call check_status_code(error, result%code, HOLOSYM_SUCCESS, "long run")
        call check(error, result%steps_done == steps, "steps done " // &
            int_str(result%steps_done))
        if (allocated(error)) return
        call check(error, result%energy_total <= drift_factor * result%energy_window, &
            "energy drift: max over the run " // real_str(result%energy_total) // &
            " > 2 x max over the first 100 steps " // real_str(result%energy_window))
        call check(error, result%constraint_max <= constraint_bound .and. &
            result%velocity_max <= constraint_bound, "constraint residuals " // &
            real_str(result%constraint_max) // ", " // real_str(result%velocity_max))
        call check(error, result%energy_window > 0, "energy error measured")
        call run_long_study(0, window, result, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "0 steps")
    end subroutine long_run_no_drift

    !> Round-off growth shortened: L_z changes by round-off only, within the random-walk
    !! envelope eps sqrt(k) at every block, with both kinds of summation.
    subroutine roundoff_growth(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(growth_result_t) :: result
        type(holosym_status_t) :: status
        integer :: k, first
        real(wp) :: centre
        call run_growth_study(128, 2, result, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "growth study")
        call check_status_code(error, result%code, HOLOSYM_SUCCESS, "growth runs")
        if (allocated(error)) return
        first = 1
        do k = 1, size(result%block_end)
            centre = (real(first, wp) + result%block_end(k)) / 2
            call check(error, result%rms_compensated(k) <= eps * sqrt(centre) .and. &
                result%rms_naive(k) <= eps * sqrt(centre), "L_z error above eps sqrt(k) in " &
                // "block " // int_str(k) // ": " // real_str(result%rms_compensated(k)) // &
                ", " // real_str(result%rms_naive(k)))
            first = result%block_end(k) + 1
        end do
        call check(error, result%rms_compensated(size(result%block_end)) > 0, "L_z measured")
        call check_close(error, fitted_exponent([1.0_wp, 4.0_wp, 16.0_wp], &
            [3.0_wp, 6.0_wp, 12.0_wp]), 0.5_wp, 0.0_wp, 8 * eps, "fitted exponent of sqrt")
        call run_growth_study(1, 2, result, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "1 step")
    end subroutine roundoff_growth

    !> Study 2 shortened: with M = 4 the error after 20 steps falls with h until the
    !! round-off band 64 eps sqrt(K): above it at h_large, inside it at h = 1e-4.
    subroutine tiny_steps(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(tiny_cell_t), allocatable :: cells(:, :)
        type(holosym_status_t) :: status
        integer, parameter :: steps = 20
        real(wp) :: band
        !> Largest step of the study, where M = 4 must be truncation-dominated: 1e-2 in
        !! real128; in real64 even h = 1e-1 is at round-off (1.1e-16), so it uses 0.5.
        real(wp), parameter :: h_large = merge(1.0e-2_wp, 0.5_wp, precision(1.0_wp) >= 30)
        band = 64 * eps * sqrt(real(steps, wp))
        call run_tiny_study([4], [h_large, 1.0e-3_wp, 1.0e-4_wp], steps, cells, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "tiny study")
        if (allocated(error)) return
        call check(error, all(cells%code == HOLOSYM_SUCCESS), "tiny runs succeed")
        call check(error, cells(1, 1)%global_error > band .and. &
            cells(1, 1)%energy_error > band, "largest h is truncation-dominated: " // &
            real_str(cells(1, 1)%global_error))
        call check(error, cells(3, 1)%global_error <= band .and. &
            cells(3, 1)%energy_error <= band, "h = 1e-4 is at round-off: " // &
            real_str(cells(3, 1)%global_error) // ", " // real_str(cells(3, 1)%energy_error))
        call check(error, cells(2, 1)%global_error < cells(1, 1)%global_error, &
            "error decreases with h")
        call check(error, maxval(cells%reference_change) <= band, "reference accurate")
        call run_tiny_study([4], [-1.0_wp], steps, cells, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "h = -1")
    end subroutine tiny_steps

    !> Study 3, the rules: Gauss-Legendre with 1..16 points, Lobatto with 2..16 points and
    !! the Lagrange basis for M = 1..15 are exact on polynomials to ~1e-32.
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

    !> Study 3 shortened: orders 2M for M = 1..3 and the conditioning grows with M.
    subroutine high_orders(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(high_order_row_t), allocatable :: rows(:)
        type(holosym_status_t) :: status
        integer :: i
        !> Step pair of the order measurement: 1/4, 1/8 in real128; in real64 the M = 3 errors
        !! there sink to round-off, so it uses 1/2, 1/4.
        real(wp), parameter :: h_pair(2) = merge([0.25_wp, 0.125_wp], [0.5_wp, 0.25_wp], &
            precision(1.0_wp) >= 30)
        call run_high_order_study(3, h_pair, 1.0_wp, rows, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "high-order study")
        if (allocated(error)) return
        do i = 1, size(rows)
            call check(error, rows(i)%order_measured, "order measured, M = " // int_str(i))
            if (allocated(error)) return
            call check(error, abs(rows(i)%order - 2 * i) <= order_agreement, "order of M = " // &
                int_str(i) // ": " // real_str(rows(i)%order))
            call check(error, rows(i)%conditioning_code == HOLOSYM_SUCCESS .and. &
                rows(i)%condition >= 1 .and. rows(i)%condition < 1 / eps, "condition of M = " &
                // int_str(i) // ": " // real_str(rows(i)%condition))
            if (i > 1) call check(error, rows(i)%pivot_ratio < rows(i - 1)%pivot_ratio .and. &
                rows(i)%condition > rows(i - 1)%condition, "conditioning worsens with M")
        end do
        call run_high_order_study(max_study_order + 1, [0.25_wp, 0.125_wp], 1.0_wp, rows, &
                                  status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "M = 16")
    end subroutine high_orders

    !> Study 4 shortened (M = 1): beyond the largest step Newton fails with a positive code,
    !! the state unchanged (step) or finite and on the manifold (run); no NaN state.
    subroutine large_steps(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(large_step_cell_t), allocatable :: cells(:)
        type(holosym_status_t) :: status
        integer :: i
        call run_large_step_study(1, cells, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "large-step study")
        if (allocated(error)) return
        call check(error, size(cells) == 2, "two systems")
        do i = 1, size(cells)
            call check(error, cells(i)%h_step > 0.125_wp .and. cells(i)%h_step_fail > &
                cells(i)%h_step, cells(i)%system // ": h range " // real_str(cells(i)%h_step))
            call check(error, cells(i)%step_fail_code > 0 .and. cells(i)%step_fail_clean, &
                cells(i)%system // ": first-step failure not clean, code " // &
                int_str(cells(i)%step_fail_code))
            call check(error, index(cells(i)%step_fail_message, "h = ") > 0, &
                cells(i)%system // ": message names h")
            call check(error, cells(i)%run_fail_code > 0 .and. cells(i)%run_fail_clean, &
                cells(i)%system // ": run failure not clean, code " // &
                int_str(cells(i)%run_fail_code))
            call check(error, cells(i)%h_run > 0 .and. cells(i)%h_run <= cells(i)%h_step * &
                (1 + 1.0e-3_wp), cells(i)%system // ": h_run " // real_str(cells(i)%h_run))
        end do
    end subroutine large_steps

    !> Study 5 shortened: k = 10^4 runs at omega h = 1 and 1/4 with constraints at
    !! round-off, and the smaller step has the smaller energy error.
    subroutine stiff_springs(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(stiff_cell_t), allocatable :: cells(:)
        type(holosym_status_t) :: status
        call run_stiff_study([1.0e4_wp], [2], [1.0_wp, 0.25_wp], 1.0_wp, cells, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "stiff study")
        if (allocated(error)) return
        call check(error, all(cells%code == HOLOSYM_SUCCESS), "stiff runs succeed")
        call check(error, all(cells%constraint_max <= constraint_bound), "stiff constraints")
        call check(error, cells(2)%energy_error < cells(1)%energy_error, "energy error falls " &
            // "with h: " // real_str(cells(1)%energy_error) // " -> " // &
            real_str(cells(2)%energy_error))
        call check(error, abs(cells(1)%h - 0.01_wp) <= 4 * eps, "h = omega h / omega")
        call run_stiff_study([-1.0_wp], [2], [1.0_wp], 1.0_wp, cells, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "k = -1")
    end subroutine stiff_springs

    !> Study 6 shortened: near-dependent constraints still run with residuals at round-off
    !! (and large multipliers); dependent ones give HOLOSYM_RANK_DEFICIENT_CONSTRAINTS.
    subroutine near_singular(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(near_singular_cell_t), allocatable :: cells(:)
        type(holosym_status_t) :: status
        !> The nearly dependent case: 1e-8 in real128; the Gram pivot ~delta**2 must stay
        !! well above n eps, so real64 uses eps**(1/4) = 1.2e-4.
        real(wp), parameter :: delta_near = max(1.0e-8_wp, sqrt(sqrt(eps)))
        call run_near_singular_study([1.0e-2_wp, delta_near, 0.0_wp], 2, 1.0_wp / 64, cells, &
                                     status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "near-singular study")
        if (allocated(error)) return
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

    ! ------------------------------------------------------------------ CLI

    !> Good and bad options of `extremes`: missing, malformed and out-of-range values are
    !! rejected with HOLOSYM_INVALID_ARGUMENT and a message naming the option and value.
    subroutine cli_options(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(extremes_options_t) :: options
        type(holosym_status_t) :: status
        type(extremes_settings_t) :: quick
        call parse_extremes_options(split_words("--part long,stiff --steps 500 --max-order 4"), &
                                    options, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "good options")
        call check(error, options%parts(1) .and. options%parts(5) .and. &
            count(options%parts) == 2, "parts long and stiff")
        call check(error, options%settings%long_steps == 500 .and. &
            options%settings%long_window == 500 .and. &
            options%settings%high_max_order == 4, "sizes")
        call parse_extremes_options(split_words("--quick --part=near-singular"), options, &
                                    status)
        quick = extremes_settings(.true.)
        call check(error, status%ok() .and. options%quick .and. options%parts(6) .and. &
            count(options%parts) == 1 .and. options%settings%long_steps == quick%long_steps, &
            "quick and inline part")
        call parse_extremes_options(split_words("--part all"), options, status)
        call check(error, status%ok() .and. all(options%parts), "all parts")
        call reject("--steps 0", [character(len=16) :: "--steps", "'0'"])
        call reject("--steps -5", [character(len=16) :: "--steps", "'-5'"])
        call reject("--steps 1e3", [character(len=16) :: "--steps", "'1e3'"])
        call reject("--steps 99999999999999999999", [character(len=16) :: "--steps", &
                    "out of range"])
        call reject("--steps", [character(len=16) :: "--steps", "a value"])
        call reject("--max-order 16", [character(len=16) :: "--max-order", "'16'"])
        call reject("--max-order 0", [character(len=16) :: "--max-order", "'0'"])
        call reject("--max-order x", [character(len=16) :: "--max-order", "'x'"])
        call reject("--part bogus", [character(len=16) :: "--part", "'bogus'"])
        call reject("--part long,", [character(len=16) :: "--part", "''"])
        call reject("--part", [character(len=16) :: "--part", "a value"])
        call reject("--frobnicate", [character(len=16) :: "--frobnicate"])

    contains

        subroutine reject(line, texts)
            character(len=*), intent(in) :: line
            character(len=*), intent(in) :: texts(:)
            integer :: k
            if (allocated(error)) return
            call parse_extremes_options(split_words(line), options, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "'" // line // &
                "'")
            do k = 1, size(texts)
                call check(error, index(status%message, trim(texts(k))) > 0, "message for '" // &
                    line // "' should name " // trim(texts(k)) // ": " // status%message)
            end do
        end subroutine reject

    end subroutine cli_options

    !> `extremes --help` and a short run in process: exit codes and Markdown output.
    subroutine cli_in_process(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: out, err, code, ios
        character(len=512) :: line
        logical :: found
        open (newunit=out, status="scratch", action="readwrite")
        open (newunit=err, status="scratch", action="readwrite")
        call extremes_command(split_words("--help"), out, err, code)
        call check(error, code == EXIT_OK, "--help exits 0")
        call extremes_command(split_words("--steps 0"), out, err, code)
        call check(error, code == EXIT_USAGE, "--steps 0 exits 2")
        rewind (out)
        call extremes_command(split_words("--quick --part near-singular"), out, err, code)
        call check(error, code == EXIT_OK, "near-singular part exits 0")
        rewind (out)
        found = .false.
        do
            read (out, '(a)', iostat=ios) line
            if (ios /= 0) exit
            if (index(line, "## 6. Near-singular") > 0) found = .true.
        end do
        call check(error, found, "the report has the near-singular section")
        close (out)
        close (err)
    end subroutine cli_in_process

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
