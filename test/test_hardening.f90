!> Tests of the library's hardening: limits of (M, N, G) and overflow-checked sizes, every
!! setting validated, NaN inputs that never raise an IEEE exception inside the library,
!! the codes of steps below the resolution of the state, of constraints that become
!! dependent within a step and of absurdly large steps, and spurious Newton roots (a step
!! must not report success on a root that is not the continuation of the flow). Every step
!! test runs on both paths: the reduced step (default for systems that declare a diagonal
!! mass) and the general scheme (`structured = .false.`).
module test_hardening
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, &
        ieee_negative_inf, ieee_is_finite
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym, only: wp, holosym_status_t, constrained_hamiltonian, constrained_integrator, &
        spherical_pendulum, planar_pendulum, energy_monitor, pendulum_chain, newton_settings_t, &
        project_to_manifold, rattle_integrator, &
        projection_report_t, max_order_m, max_order_n, max_gauss_points, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_DIMENSION, &
        HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NONFINITE_VALUE, &
        HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
        HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, HOLOSYM_STEP_TOO_LARGE, HOLOSYM_STEP_TOO_SMALL
    use holosym_internal, only: newton_report_t, newton_solve, nonlinear_system, unknown_count
    use holosym_status_codes, only: int_str, real_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code, &
        skip, overflow_traps
    implicit none
    private
    public :: hardening_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Bound on the relative energy error and on the distance from a run with h/8 of every
    !! step reported as success at large step sizes.
    real(wp), parameter :: criterion = 1.0e-2_wp

    !> A charged particle on the unit sphere in a uniform magnetic field B along z, with
    !! gravity g along -z: H = |p - A(q)|^2/2 + g z, A = (B/2)(-y, x, 0), phi = |q|^2 - 1.
    !! Not separable: it takes the general path.
    type, extends(constrained_hamiltonian) :: magnetic_sphere
        real(wp) :: field = 1.3_wp
        real(wp) :: gravity = 1
    contains
        procedure :: hamiltonian => magnetic_hamiltonian
        procedure :: dh_dq => magnetic_dh_dq
        procedure :: dh_dp => magnetic_dh_dp
        procedure :: constraint => magnetic_constraint
        procedure :: constraint_jacobian => magnetic_constraint_jacobian
        procedure :: hessian => magnetic_hessian
        procedure :: constraint_hessian => magnetic_constraint_hessian
    end type magnetic_sphere

    !> A free particle in space on the x axis: phi = (z, z + f(x) y) with f(x) = x^2 for
    !! x < 0 and 0 for x >= 0, H = |p|^2/2 with unit masses declared. Moving along x it
    !! stays on the axis; the constraint gradients (0, 0, 1) and (f' y, f, 1) are
    !! independent for x < 0 and the same for x >= 0.
    type, extends(constrained_hamiltonian) :: axis_particle
    contains
        procedure :: hamiltonian => axis_hamiltonian
        procedure :: dh_dq => axis_dh_dq
        procedure :: dh_dp => axis_dh_dp
        procedure :: constraint => axis_constraint
        procedure :: constraint_jacobian => axis_constraint_jacobian
        procedure :: diagonal_mass => axis_diagonal_mass
    end type axis_particle

    !> The spherical pendulum whose dh_dq is NaN everywhere.
    type, extends(spherical_pendulum) :: nan_pendulum
    contains
        procedure :: dh_dq => nan_dh_dq
    end type nan_pendulum

    !> The spherical pendulum whose Hamiltonian is NaN everywhere (its gradients are right).
    type, extends(spherical_pendulum) :: nan_energy_pendulum
        !> Calls of `hamiltonian` (when associated); H is NaN from call `nan_from` on.
        integer, pointer :: calls => null()
        integer :: nan_from = 0
    contains
        procedure :: hamiltonian => nan_hamiltonian
    end type nan_energy_pendulum

    !> The spherical pendulum whose constraint counts its calls in `calls` and returns NaN
    !! from call number `nan_from` on.
    type, extends(spherical_pendulum) :: late_nan_pendulum
        integer, pointer :: calls => null()
        integer :: nan_from = huge(0)
    contains
        procedure :: constraint => late_nan_constraint
    end type late_nan_pendulum

    !> A system with settable sizes that is never evaluated (sizes only).
    type, extends(constrained_hamiltonian) :: sized_system
        logical :: declares_mass = .false.
    contains
        procedure :: hamiltonian => sized_hamiltonian
        procedure :: dh_dq => sized_gradient
        procedure :: dh_dp => sized_gradient
        procedure :: constraint => sized_constraint
        procedure :: constraint_jacobian => sized_constraint_jacobian
        procedure :: diagonal_mass => sized_diagonal_mass
    end type sized_system

    !> x^2 = 2 as a nonlinear system, for newton_solve itself.
    type, extends(nonlinear_system) :: square_root_system
    contains
        procedure :: residual => square_residual
        procedure :: jacobian => square_jacobian
    end type square_root_system

contains

    !> A constrained_integrator with its default settings (a structure constructor with
    !! no values is refused by compilers for components without defaults, e.g. flang).
    function new_integrator() result(integ)
        type(constrained_integrator) :: integ
    end function new_integrator

    !> The tests of this suite.
    function hardening_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("limits_of_m_n_g", limits_of_orders), &
            new_test("sizes_that_overflow", sizes_that_overflow), &
            new_test("every_setting_validated", settings_validated), &
            new_test("newton_solve_validates_its_settings", newton_settings_checked), &
            new_test("rattle_validates_settings_and_sizes", rattle_checked), &
            new_test("nan_inputs_never_raise_invalid", nan_inputs_never_trap), &
            new_test("nan_energy_or_end_of_step_nan_is_code_4", nan_from_the_system), &
            new_test("overflowing_energy_at_the_start_is_code_4", overflowing_energy), &
            new_test("tiny_steps_below_resolution", tiny_steps), &
            new_test("constraints_dependent_within_a_step", dependent_within_step), &
            new_test("absurd_step_sizes", absurd_steps), &
            new_test("root_check_keeps_ordinary_steps", ordinary_steps_unchanged), &
            new_test("spurious_roots_magnetic_sphere", spurious_magnetic), &
            new_test("spurious_roots_double_pendulum", spurious_double_pendulum) &
            ]
    end function hardening_tests

    ! ------------------------------------------------------------------ test systems

    pure function magnetic_velocity(self, q, p) result(v)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: v(3)
        v(1) = p(1) + self%field / 2 * q(2)
        v(2) = p(2) - self%field / 2 * q(1)
        v(3) = p(3)
    end function magnetic_velocity

    function magnetic_hamiltonian(self, q, p) result(energy)
        class(magnetic_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)               !! coordinates
        real(wp), intent(in) :: p(:)               !! momenta
        real(wp) :: energy
        energy = sum(magnetic_velocity(self, q, p)**2) / 2 + self%gravity * q(3)
    end function magnetic_hamiltonian

    subroutine magnetic_dh_dq(self, q, p, gradient)
        class(magnetic_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)               !! coordinates
        real(wp), intent(in) :: p(:)               !! momenta
        real(wp), intent(out) :: gradient(:)       !! dH/dq
        real(wp) :: v(3)
        v = magnetic_velocity(self, q, p)
        gradient(1) = -self%field / 2 * v(2)
        gradient(2) = self%field / 2 * v(1)
        gradient(3) = self%gravity
    end subroutine magnetic_dh_dq

    subroutine magnetic_dh_dp(self, q, p, gradient)
        class(magnetic_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)               !! coordinates
        real(wp), intent(in) :: p(:)               !! momenta
        real(wp), intent(out) :: gradient(:)       !! dH/dp
        gradient = magnetic_velocity(self, q, p)
    end subroutine magnetic_dh_dp

    subroutine magnetic_constraint(self, q, phi)
        class(magnetic_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)               !! coordinates
        real(wp), intent(out) :: phi(:)            !! |q|^2 - 1
        phi(1) = sum(q**2) - 1
    end subroutine magnetic_constraint

    subroutine magnetic_constraint_jacobian(self, q, jacobian)
        class(magnetic_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)               !! coordinates
        real(wp), intent(out) :: jacobian(:, :)    !! 2 q^T
        jacobian(1, :) = 2 * q
    end subroutine magnetic_constraint_jacobian

    subroutine magnetic_hessian(self, q, p, hqq, hqp, hpp)
        class(magnetic_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)               !! coordinates
        real(wp), intent(in) :: p(:)               !! momenta
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :) !! second derivatives
        real(wp) :: half
        half = self%field / 2
        hqq = 0
        hqp = 0
        hpp = 0
        hqq(1, 1) = half**2
        hqq(2, 2) = half**2
        hqp(1, 2) = -half
        hqp(2, 1) = half
        hpp(1, 1) = 1
        hpp(2, 2) = 1
        hpp(3, 3) = 1
    end subroutine magnetic_hessian

    subroutine magnetic_constraint_hessian(self, q, hessian)
        class(magnetic_sphere), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)               !! coordinates
        real(wp), intent(out) :: hessian(:, :, :)  !! 2 I
        integer :: i
        hessian = 0
        do i = 1, 3
            hessian(i, i, 1) = 2
        end do
    end subroutine magnetic_constraint_hessian

    function axis_hamiltonian(self, q, p) result(energy)
        class(axis_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(in) :: p(:)             !! momenta
        real(wp) :: energy
        energy = sum(p**2) / 2
    end function axis_hamiltonian

    subroutine axis_dh_dq(self, q, p, gradient)
        class(axis_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(in) :: p(:)             !! momenta
        real(wp), intent(out) :: gradient(:)     !! 0
        gradient = 0
    end subroutine axis_dh_dq

    subroutine axis_dh_dp(self, q, p, gradient)
        class(axis_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(in) :: p(:)             !! momenta
        real(wp), intent(out) :: gradient(:)     !! p
        gradient = p
    end subroutine axis_dh_dp

    subroutine axis_constraint(self, q, phi)
        class(axis_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(out) :: phi(:)          !! (z, z + f(x) y)
        phi(1) = q(3)
        phi(2) = q(3) + min(q(1), 0.0_wp)**2 * q(2)
    end subroutine axis_constraint

    subroutine axis_constraint_jacobian(self, q, jacobian)
        class(axis_particle), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)             !! coordinates
        real(wp), intent(out) :: jacobian(:, :)  !! Phi
        jacobian(1, :) = [0.0_wp, 0.0_wp, 1.0_wp]
        jacobian(2, :) = [2 * min(q(1), 0.0_wp) * q(2), min(q(1), 0.0_wp)**2, 1.0_wp]
    end subroutine axis_constraint_jacobian

    logical function axis_diagonal_mass(self, mass) result(declared)
        class(axis_particle), intent(in) :: self !! the system
        real(wp), intent(out) :: mass(:)         !! unit masses
        mass = 1
        declared = .true.
    end function axis_diagonal_mass

    function nan_hamiltonian(self, q, p) result(energy)
        class(nan_energy_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        integer :: call_number
        call_number = huge(0)
        if (associated(self%calls)) then
            self%calls = self%calls + 1
            call_number = self%calls
        end if
        if (call_number >= self%nan_from) then
            energy = ieee_value(1.0_wp, ieee_quiet_nan)
        else
            energy = self%spherical_pendulum%hamiltonian(q, p)
        end if
    end function nan_hamiltonian

    subroutine late_nan_constraint(self, q, phi)
        class(late_nan_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        self%calls = self%calls + 1
        if (self%calls >= self%nan_from) then
            phi = ieee_value(1.0_wp, ieee_quiet_nan)
        else
            call self%spherical_pendulum%constraint(q, phi)
        end if
    end subroutine late_nan_constraint

    subroutine nan_dh_dq(self, q, p, gradient)
        class(nan_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)            !! coordinates
        real(wp), intent(in) :: p(:)            !! momenta
        real(wp), intent(out) :: gradient(:)    !! NaN
        gradient = ieee_value(1.0_wp, ieee_quiet_nan)
    end subroutine nan_dh_dq

    function sized_hamiltonian(self, q, p) result(energy)
        class(sized_system), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)            !! coordinates
        real(wp), intent(in) :: p(:)            !! momenta
        real(wp) :: energy
        energy = 0
    end function sized_hamiltonian

    subroutine sized_gradient(self, q, p, gradient)
        class(sized_system), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)            !! coordinates
        real(wp), intent(in) :: p(:)            !! momenta
        real(wp), intent(out) :: gradient(:)    !! 0
        gradient = 0
    end subroutine sized_gradient

    subroutine sized_constraint(self, q, phi)
        class(sized_system), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)            !! coordinates
        real(wp), intent(out) :: phi(:)         !! 0
        phi = 0
    end subroutine sized_constraint

    subroutine sized_constraint_jacobian(self, q, jacobian)
        class(sized_system), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)            !! coordinates
        real(wp), intent(out) :: jacobian(:, :) !! 0
        jacobian = 0
    end subroutine sized_constraint_jacobian

    logical function sized_diagonal_mass(self, mass) result(declared)
        class(sized_system), intent(in) :: self !! the system
        real(wp), intent(out) :: mass(:)        !! unit masses
        mass = 1
        declared = self%declares_mass
    end function sized_diagonal_mass

    subroutine square_residual(self, x, f, status)
        class(square_root_system), intent(inout) :: self   !! the system
        real(wp), intent(in) :: x(:)                       !! unknowns
        real(wp), intent(out) :: f(:)                      !! x^2 - 2
        type(holosym_status_t), intent(out) :: status      !! success
        f = x**2 - 2
        status%code = HOLOSYM_SUCCESS
    end subroutine square_residual

    subroutine square_jacobian(self, x, jac, status)
        class(square_root_system), intent(inout) :: self   !! the system
        real(wp), intent(in) :: x(:)                       !! unknowns
        real(wp), intent(out) :: jac(:, :)                 !! 2 x
        type(holosym_status_t), intent(out) :: status      !! success
        jac = 0
        jac(1, 1) = 2 * x(1)
        status%code = HOLOSYM_SUCCESS
    end subroutine square_jacobian

    ! ------------------------------------------------------------------ helpers

    !> True when a and b have the same size and the same bits.
    logical function same_bits(a, b)
        real(wp), intent(in) :: a(:), b(:)
        same_bits = size(a) == size(b)
        if (same_bits) same_bits = all(transfer(a, [0_int64]) == transfer(b, [0_int64]))
    end function same_bits

    !> "reduced" or "general", for labels.
    pure function path_name(structured) result(name)
        logical, intent(in) :: structured
        character(len=:), allocatable :: name
        if (structured) then
            name = "reduced"
        else
            name = "general"
        end if
    end function path_name

    !> Check that `message` contains `text`.
    subroutine check_mentions(error, message, text, label)
        type(test_error_t), allocatable, intent(inout) :: error
        character(len=:), allocatable, intent(in) :: message
        character(len=*), intent(in) :: text, label
        if (allocated(error)) return
        call check(error, allocated(message), label // ": no message")
        if (allocated(error)) return
        call check(error, index(message, text) > 0, label // ": message '" // message // &
            "' does not mention '" // text // "'")
    end subroutine check_mentions

    !> A step from (q0, p0) with h on the given path must fail with `code`, leave the state
    !! unchanged and (optionally) mention `text`.
    subroutine check_step_fails(error, sys, q0, p0, order_m, h, structured, code, label, &
                                text, absent)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: order_m, code
        logical, intent(in) :: structured
        character(len=*), intent(in) :: label
        character(len=*), intent(in), optional :: text   !! must be in the message
        character(len=*), intent(in), optional :: absent !! must not be in the message
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(size(q0)), p(size(p0))
        character(len=:), allocatable :: full
        if (allocated(error)) return
        full = label // " (" // path_name(structured) // ")"
        integ%structured = structured
        call integ%init(sys, order_m, order_m - 1, order_m + 1, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, full // ": init")
        if (allocated(error)) return
        q = q0
        p = p0
        call integ%step(sys, q, p, h, status=status)
        call check_status_code(error, status%code, code, full)
        call check(error, same_bits(q, q0) .and. same_bits(p, p0), full // ": state changed")
        if (present(text)) call check_mentions(error, status%message, text, full)
        if (present(absent) .and. .not. allocated(error)) call check(error, &
            index(status%message, absent) == 0, full // ": message '" // status%message // &
            "' mentions '" // absent // "'")
    end subroutine check_step_fails

    ! ------------------------------------------------------------------ 1, 14: limits

    !> M, N, G beyond their limits (also huge(1), whose default G = max(M, N) + 1 would
    !! overflow) fail at init with HOLOSYM_INVALID_ORDER and a message naming the limit;
    !! the largest allowed values work on both paths.
    subroutine limits_of_orders(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        logical :: structured
        integer :: k
        sys = spherical_pendulum()
        call one(huge(1), 0, 1, "M must be in 1.." // int_str(max_order_m))
        call one(max_order_m + 1, max_order_m, max_order_m + 2, "M must be in 1..")
        call one(2, max_order_n + 1, max_order_n + 2, "N must be in 0.." // &
            int_str(max_order_n))
        call one(2, huge(1), 3, "N must be in 0..")
        call one(2, 1, max_gauss_points + 1, "G must be in 1.." // int_str(max_gauss_points))
        call one(2, 1, huge(1), "G must be in 1..")
        call one(-huge(1) - 1, 0, 1, "got M = " // int_str(-huge(1) - 1))
        call check(error, max_order_m == 30 .and. max_order_n == 30 .and. &
            max_gauss_points == 64, "documented limits 30, 30, 64")
        do k = 1, 2
            structured = k == 1
            integ%structured = structured
            call integ%init(sys, max_order_m, max_order_n, max_gauss_points, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "init at the limits")
            call sys%initial_state(q, p)
            call integ%step(sys, q, p, 0.125_wp, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, &
                "step at the limits (" // path_name(structured) // ")")
        end do

    contains

        subroutine one(order_m, order_n, gauss_points, text)
            integer, intent(in) :: order_m, order_n, gauss_points
            character(len=*), intent(in) :: text
            type(constrained_integrator) :: fresh
            if (allocated(error)) return
            call fresh%init(sys, order_m, order_n, gauss_points, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ORDER, "init (" // &
                int_str(order_m) // ", " // int_str(order_n) // ", " // int_str(gauss_points) &
                // ")")
            call check_mentions(error, status%message, text, "init")
        end subroutine one

    end subroutine limits_of_orders

    !> Sizes that overflow the default integer: the unknown count reports it (-1), init
    !! fails with HOLOSYM_INVALID_DIMENSION for the general scheme, and a reduced step whose
    !! default dense patterns cannot be sized fails with a message asking for the sparsity.
    subroutine sizes_that_overflow(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(sized_system) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        call check(error, unknown_count(30, 30, huge(1) / 2, 0) == -1, &
            "unknown_count overflow gives -1")
        call check(error, unknown_count(2, 1, 3, 1) == 15, "unknown_count(2, 1, 3, 1) = 15")
        sys%n = huge(1) / 40
        sys%m = 0
        call integ%init(sys, 30, 29, 31, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_DIMENSION, &
            "init with n_x beyond huge(1)")
        call check_mentions(error, status%message, "default integer", "n_x overflow")
        ! n^2 overflows; the general scheme refuses, the reduced one asks for a pattern.
        sys%n = 50000
        sys%m = 0
        integ%structured = .false.
        call integ%init(sys, 2, 1, 3, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_DIMENSION, &
            "general scheme with n^2 beyond huge(1)")
        sys%declares_mass = .true.
        integ%structured = .true.
        call integ%init(sys, 2, 1, 3, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, &
            "reduced step with a dense default pattern of n^2 entries")
        call check_mentions(error, status%message, "declare the sparsity", "n^2 pattern")
    end subroutine sizes_that_overflow

    ! ------------------------------------------------------------------ 11: settings

    !> Every setting out of its range (NaN, negative, zero, one or more where it must be
    !! below one) fails step and integrate with HOLOSYM_INVALID_ARGUMENT naming the setting,
    !! the state unchanged, on both paths.
    subroutine settings_validated(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        real(wp) :: nan, inf
        logical :: structured
        integer :: k
        nan = ieee_value(1.0_wp, ieee_quiet_nan)
        inf = ieee_value(1.0_wp, ieee_positive_inf)
        sys = spherical_pendulum()
        do k = 1, 2
            structured = k == 1
            call real_setting("tolerance", [nan, -1.0_wp, 0.0_wp, 1.0_wp, inf])
            call real_setting("stagnation_level", [nan, -1.0_wp, 1.0_wp, inf])
            call real_setting("pivot_tolerance", [nan, 1.0_wp, inf])
            call real_setting("contraction_limit", [nan, -0.5_wp, 1.0_wp, -inf])
            call real_setting("jacobian_cost", [nan, -inf, inf])
            call real_setting("manifold_tolerance", [nan, 0.0_wp, -1.0_wp, 1.0_wp, inf])
            call integer_setting("max_iterations", [0, -1])
            call integer_setting("max_growth", [0, -5])
        end do

    contains

        subroutine real_setting(name, values)
            character(len=*), intent(in) :: name
            real(wp), intent(in) :: values(:)
            type(constrained_integrator) :: integ
            integer :: i
            do i = 1, size(values)
                integ = new_integrator()
                select case (name)
                case ("tolerance")
                    integ%newton%tolerance = values(i)
                case ("stagnation_level")
                    integ%newton%stagnation_level = values(i)
                case ("pivot_tolerance")
                    integ%newton%pivot_tolerance = values(i)
                case ("contraction_limit")
                    integ%newton%contraction_limit = values(i)
                case ("jacobian_cost")
                    integ%newton%jacobian_cost = values(i)
                case ("manifold_tolerance")
                    integ%manifold_tolerance = values(i)
                end select
                call one(integ, name, name // " = " // real_str(values(i)))
            end do
        end subroutine real_setting

        subroutine integer_setting(name, values)
            character(len=*), intent(in) :: name
            integer, intent(in) :: values(:)
            type(constrained_integrator) :: integ
            integer :: i
            do i = 1, size(values)
                integ = new_integrator()
                select case (name)
                case ("max_iterations")
                    integ%newton%max_iterations = values(i)
                case ("max_growth")
                    integ%newton%max_growth = values(i)
                end select
                call one(integ, name, name // " = " // int_str(values(i)))
            end do
        end subroutine integer_setting

        subroutine one(integ, name, label)
            type(constrained_integrator), intent(inout) :: integ
            character(len=*), intent(in) :: name, label
            type(holosym_status_t) :: status
            real(wp) :: q0(3), p0(3), q(3), p(3)
            integer :: done
            if (allocated(error)) return
            integ%structured = structured
            call integ%init(sys, 2, 1, 3, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, label // ": init")
            call sys%initial_state(q0, p0)
            q = q0
            p = p0
            call integ%step(sys, q, p, 0.125_wp, status=status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "step, " // &
                label // " (" // path_name(structured) // ")")
            call check_mentions(error, status%message, name, label)
            call check(error, same_bits(q, q0) .and. same_bits(p, p0), label // ": state")
            call integ%integrate(sys, q, p, 0.125_wp, 3, steps_done=done, status=status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, &
                "integrate, " // label)
            call check(error, done == 0 .and. same_bits(q, q0) .and. same_bits(p, p0), &
                label // ": integrate moved")
        end subroutine one

    end subroutine settings_validated

    !> newton_solve itself rejects settings out of range, a non-finite first guess and a
    !! negative or non-finite scale (HOLOSYM_INVALID_ARGUMENT, x unchanged), and solves
    !! x^2 = 2 with valid ones.
    subroutine newton_settings_checked(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(square_root_system) :: system
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report
        type(holosym_status_t) :: status
        real(wp) :: x(1), nan
        nan = ieee_value(1.0_wp, ieee_quiet_nan)
        settings = newton_settings_t()
        settings%tolerance = nan
        call one(settings, [1.0_wp], 1.0_wp, "tolerance")
        settings = newton_settings_t()
        settings%max_growth = 0
        call one(settings, [1.0_wp], 1.0_wp, "max_growth")
        settings = newton_settings_t()
        settings%pivot_tolerance = 2
        call one(settings, [1.0_wp], 1.0_wp, "pivot_tolerance")
        settings = newton_settings_t()
        settings%stagnation_level = -1
        call one(settings, [1.0_wp], 1.0_wp, "stagnation_level")
        call one(newton_settings_t(), [nan], 1.0_wp, "first guess")
        call one(newton_settings_t(), [1.0_wp], nan, "scale")
        call one(newton_settings_t(), [1.0_wp], -1.0_wp, "scale")
        x = 1
        call newton_solve(system, x, newton_settings_t(), 1.0_wp, report, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "x^2 = 2")
        call check(error, abs(x(1) - sqrt(2.0_wp)) <= 4 * eps, "x = sqrt 2")

    contains

        subroutine one(bad, guess, scale, name)
            type(newton_settings_t), intent(in) :: bad
            real(wp), intent(in) :: guess(1), scale
            character(len=*), intent(in) :: name
            if (allocated(error)) return
            x = guess
            call newton_solve(system, x, bad, scale, report, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, &
                "newton_solve, bad " // name)
            call check_mentions(error, status%message, name, "newton_solve")
            call check(error, same_bits(x, guess), "newton_solve, bad " // name // &
                ": x changed")
        end subroutine one

    end subroutine newton_settings_checked

    !> The RATTLE baseline checks its sizes at init (n < 1, m >= n, a workspace beyond the
    !! default integer: HOLOSYM_INVALID_DIMENSION) and its settings at each step (tolerance
    !! NaN or outside (0, 1), max_iterations < 1: HOLOSYM_INVALID_ARGUMENT, state unchanged).
    subroutine rattle_checked(error)
        use holosym, only: HOLOSYM_INVALID_DIMENSION
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(sized_system) :: sized
        type(rattle_integrator) :: rattle
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q(3), p(3)
        sized%n = 2
        sized%m = 2
        call rattle%init(sized, 2, "triple-jump", status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_DIMENSION, "rattle m = n")
        sized%n = huge(1) / 2
        sized%m = 1
        call rattle%init(sized, 2, "triple-jump", status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_DIMENSION, "rattle huge n")
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        call rattle%init(sys, 4, "triple-jump", status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "rattle init")
        q = q0
        p = p0
        rattle%tolerance = ieee_value(1.0_wp, ieee_quiet_nan)
        call rattle%step(sys, q, p, 0.125_wp, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "rattle NaN tol")
        rattle%tolerance = 2
        call rattle%step(sys, q, p, 0.125_wp, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "rattle tol 2")
        rattle%tolerance = 8 * eps
        rattle%max_iterations = 0
        call rattle%step(sys, q, p, 0.125_wp, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "rattle 0 iter")
        call check(error, same_bits(q, q0) .and. same_bits(p, p0), "rattle moved the state")
        rattle%max_iterations = 50
        call rattle%step(sys, q, p, 0.125_wp, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "rattle valid step")
    end subroutine rattle_checked

    ! ------------------------------------------------------------------ 12: no traps

    !> With 'invalid' and 'divide by zero' halting (as under -ffpe-trap=invalid,zero), NaN
    !! and infinite inputs reach the documented codes without a floating-point exception
    !! inside the library: a NaN or infinite h, q, p, tau or setting, a system returning
    !! NaN, a NaN start for the projection. (An ordered comparison with a NaN raises
    !! 'invalid'; the library's checks are IEEE classifications.)
    subroutine nan_inputs_never_trap(error)
        use, intrinsic :: ieee_exceptions, only: ieee_set_halting_mode, ieee_invalid, &
            ieee_divide_by_zero, ieee_support_halting
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(nan_pendulum), target :: faulty
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        type(projection_report_t) :: projection
        type(newton_settings_t) :: defaults
        real(wp) :: q0(3), p0(3), q(3), p(3), lambda(1), nan, inf
        logical :: structured
        integer :: k
        if (.not. (ieee_support_halting(ieee_invalid) .and. &
                   ieee_support_halting(ieee_divide_by_zero))) then
            call skip(error, "no halting on IEEE exceptions on this processor")
            return
        end if
        nan = ieee_value(1.0_wp, ieee_quiet_nan)
        inf = ieee_value(1.0_wp, ieee_positive_inf)
        sys = spherical_pendulum()
        faulty%spherical_pendulum = spherical_pendulum()
        call sys%initial_state(q0, p0)
        ! Restored on return: this procedure uses ieee_exceptions itself.
        call ieee_set_halting_mode(ieee_invalid, .true.)
        call ieee_set_halting_mode(ieee_divide_by_zero, .true.)
        do k = 1, 2
            structured = k == 1
            integ = new_integrator()
            integ%structured = structured
            call integ%init(sys, 2, 1, 3, status)
            call one_step(nan, q0, p0, HOLOSYM_INVALID_STEP_SIZE, "h = NaN")
            call one_step(-inf, q0, p0, HOLOSYM_INVALID_STEP_SIZE, "h = -Inf")
            call one_step(inf, q0, p0, HOLOSYM_INVALID_STEP_SIZE, "h = Inf")
            call one_step(0.125_wp, [nan, q0(2:)], p0, HOLOSYM_INVALID_ARGUMENT, "q NaN")
            call one_step(0.125_wp, q0, [inf, p0(2:)], HOLOSYM_INVALID_ARGUMENT, "p Inf")
            integ%newton%tolerance = nan
            call one_step(0.125_wp, q0, p0, HOLOSYM_INVALID_ARGUMENT, "tolerance NaN")
            integ%newton%tolerance = defaults%tolerance
            integ%manifold_tolerance = nan
            call one_step(0.125_wp, q0, p0, HOLOSYM_INVALID_ARGUMENT, "manifold NaN")
            integ%manifold_tolerance = 1.0e-20_wp
            integ%newton%contraction_limit = nan
            call one_step(0.125_wp, q0, p0, HOLOSYM_INVALID_ARGUMENT, "contraction NaN")
            integ%newton%contraction_limit = defaults%contraction_limit
            integ%manifold_tolerance = 1024 * eps
            q = q0
            p = p0
            call integ%step(sys, q, p, 0.125_wp, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "valid step")
            call integ%dense_output(nan, q, p, lambda, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "tau NaN")
            if (allocated(error)) return
            integ = new_integrator()
            integ%structured = structured
            call integ%init(faulty, 2, 1, 3, status)
            q = q0
            p = p0
            call integ%step(faulty, q, p, 0.125_wp, status=status)
            call check_status_code(error, status%code, HOLOSYM_NONFINITE_VALUE, &
                "dh_dq NaN (" // path_name(structured) // ")")
        end do
        q = [nan, 0.0_wp, 1.0_wp]
        p = 0
        call project_to_manifold(sys, q, p, status, report=projection)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "projection NaN")

    contains

        subroutine one_step(h, q_start, p_start, code, label)
            real(wp), intent(in) :: h, q_start(3), p_start(3)
            integer, intent(in) :: code
            character(len=*), intent(in) :: label
            if (allocated(error)) return
            q = q_start
            p = p_start
            call integ%step(sys, q, p, h, status=status)
            call check_status_code(error, status%code, code, label // " (" // &
                path_name(structured) // ")")
        end subroutine one_step

    end subroutine nan_inputs_never_trap

    !> A NaN from the system where the library evaluates it after Newton converged is
    !! HOLOSYM_NONFINITE_VALUE, without a floating-point exception ('invalid' halting, as
    !! in `nan_inputs_never_raise_invalid`), never a success: a Hamiltonian that is NaN
    !! everywhere (its gradients right, so every step converges; the energy check of each
    !! step evaluates H), and a constraint that turns NaN at its last call of a step, the
    !! end-of-step residual at the displacement nodes. Both paths.
    subroutine nan_from_the_system(error)
        use, intrinsic :: ieee_exceptions, only: ieee_set_halting_mode, ieee_invalid, &
            ieee_support_halting
        type(test_error_t), allocatable, intent(out) :: error
        type(nan_energy_pendulum), target :: no_energy
        type(late_nan_pendulum), target :: late
        type(constrained_integrator) :: integ
        type(energy_monitor) :: monitor
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q(3), p(3)
        integer, target :: calls
        integer :: k, steps_done, per_step
        logical :: structured
        if (.not. ieee_support_halting(ieee_invalid)) then
            call skip(error, "no halting on IEEE exceptions on this processor")
            return
        end if
        no_energy%spherical_pendulum = spherical_pendulum()
        late%spherical_pendulum = spherical_pendulum()
        late%calls => calls
        call no_energy%initial_state(q0, p0)
        call ieee_set_halting_mode(ieee_invalid, .true.)
        do k = 1, 2
            structured = k == 1
            integ = new_integrator()
            integ%structured = structured
            integ%check_system = .false.      ! the check would find the NaN H first
            call integ%init(no_energy, 2, 1, 3, status)
            q = q0
            p = p0
            call integ%integrate(no_energy, q, p, 0.125_wp, 20, steps_done=steps_done, &
                status=status)
            call check_status_code(error, status%code, HOLOSYM_NONFINITE_VALUE, &
                "H NaN (" // path_name(structured) // ")")
            if (allocated(error)) return
            call check(error, steps_done == 0 .and. index(status%message, "hamiltonian") > 0, &
                "H NaN: no step accepted, the message names hamiltonian (" // &
                path_name(structured) // "): " // status%message)
            if (allocated(error)) return
            ! The calls of one step from a fresh start, then the same step with the last
            ! of them NaN.
            integ = new_integrator()
            integ%structured = structured
            integ%check_system = .false.
            call integ%init(late, 2, 1, 3, status)
            calls = 0
            q = q0
            p = p0
            call integ%step(late, q, p, 0.125_wp, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "late NaN: counting")
            if (allocated(error)) return
            per_step = calls
            integ = new_integrator()
            integ%structured = structured
            integ%check_system = .false.
            call integ%init(late, 2, 1, 3, status)
            calls = 0
            late%nan_from = per_step
            q = q0
            p = p0
            call integ%step(late, q, p, 0.125_wp, status=status)
            late%nan_from = huge(0)
            call check_status_code(error, status%code, HOLOSYM_NONFINITE_VALUE, &
                "constraint NaN at the end-of-step residual (" // path_name(structured) // ")")
            if (allocated(error)) return
            call check(error, all(q == q0) .and. all(p == p0), "state unchanged on failure")
            if (allocated(error)) return
        end do
        ! With the root check off the integrator does not evaluate H; the monitor does, and
        ! records an unbounded energy error, without a trap, when H turns NaN after a step.
        no_energy%calls => calls
        calls = 0
        no_energy%nan_from = 3                ! the monitor's start, the first step, NaN
        integ = new_integrator()
        integ%check_system = .false.
        integ%check_roots = .false.
        call integ%init(no_energy, 2, 1, 3, status)
        q = q0
        p = p0
        call monitor%start(no_energy, q, p, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "monitor start")
        if (allocated(error)) return
        call integ%integrate(no_energy, q, p, 0.125_wp, 4, observer=monitor, status=status)
        call check(error, status%ok() .and. monitor%steps == 4 .and. &
            .not. ieee_is_finite(monitor%max_energy_error), &
            "H NaN after step 2, root check off: the monitor's energy error is not finite")
    end subroutine nan_from_the_system

    !> A start state whose energy overflows (|p| = huge**0.6, on the manifold) is
    !! HOLOSYM_NONFINITE_VALUE naming the Hamiltonian, not a Newton code. Skipped where
    !! overflow traps (the pendulum's own H overflows).
    subroutine overflowing_energy(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q0(3), p0(3), q(3), p(3), big
        integer :: k
        logical :: structured
        if (overflow_traps()) then
            call skip(error, "computes an overflow on purpose")
            return
        end if
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        big = huge(1.0_wp)**0.6_wp
        ! A tangent direction: q0 x e_z, scaled.
        p0 = big * [q0(2), -q0(1), 0.0_wp] / norm2(q0(1:2))
        do k = 1, 2
            structured = k == 1
            integ = new_integrator()
            integ%structured = structured
            integ%check_system = .false.      ! the check finds it too: the step's own test
            call integ%init(sys, 2, 1, 3, status)
            q = q0
            p = p0
            call integ%step(sys, q, p, 0.125_wp, status=status)
            call check_status_code(error, status%code, HOLOSYM_NONFINITE_VALUE, &
                "H overflows at the start (" // path_name(structured) // ")")
            if (allocated(error)) return
            call check(error, index(status%message, "hamiltonian") > 0, &
                "the message names hamiltonian: " // status%message)
            if (allocated(error)) return
        end do
    end subroutine overflowing_energy

    ! ------------------------------------------------------------------ 7: tiny steps

    !> Legal steps below the resolution of the state fail with HOLOSYM_STEP_TOO_SMALL,
    !! whose message gives the limit, and never with a Newton code (1, 2, 3) or a success
    !! of garbage; larger steps still succeed. Cases: runs with h = 1e-14 on the
    !! spherical pendulum and 1e-15 on the planar one (real128; in real64 the same distance
    !! below the limit), and much smaller steps down to a subnormal h.
    subroutine tiny_steps(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sphere
        type(planar_pendulum), target :: planar
        real(wp) :: q3(3), p3(3), q2(2), p2(2), scale_down
        logical :: structured
        integer :: k
        sphere = spherical_pendulum()
        planar = planar_pendulum()
        call sphere%initial_state(q3, p3)
        call planar%initial_state(q2, p2)
        ! The resolution limit scales like epsilon**(1/3) (epsilon over its two-thirds
        ! power, the stagnation level).
        scale_down = (eps / 1.93e-34_wp)**(1.0_wp / 3)
        if (eps < 1.0e-30_wp) scale_down = 1
        do k = 1, 2
            structured = k == 1
            call check_run(sphere, q3, p3, 1.0e-14_wp * scale_down, 50, &
                HOLOSYM_STEP_TOO_SMALL, "sphere h = 1e-14")
            call check_run(planar, q2, p2, 1.0e-15_wp * scale_down, 50, &
                HOLOSYM_STEP_TOO_SMALL, "planar h = 1e-15")
            call check_run(sphere, q3, p3, eps, 2, HOLOSYM_STEP_TOO_SMALL, &
                "sphere h = epsilon")
            call check_run(sphere, q3, p3, tiny(1.0_wp)**0.25_wp, 2, HOLOSYM_STEP_TOO_SMALL, &
                "sphere h = tiny**(1/4)")
            call check_run(planar, q2, p2, tiny(1.0_wp) / 4, 2, HOLOSYM_STEP_TOO_SMALL, &
                "planar h subnormal", "smallest normal")
            call check_run(sphere, q3, p3, eps**0.125_wp, 4, HOLOSYM_SUCCESS, &
                "sphere h = epsilon**(1/8)")
        end do

    contains

        subroutine check_run(sys, q0, p0, h, steps, code, label, text)
            class(constrained_hamiltonian), intent(in), target :: sys
            real(wp), intent(in) :: q0(:), p0(:), h
            integer, intent(in) :: steps, code
            character(len=*), intent(in) :: label
            character(len=*), intent(in), optional :: text
            type(constrained_integrator) :: integ
            type(holosym_status_t) :: status
            real(wp) :: q(size(q0)), p(size(p0))
            character(len=:), allocatable :: full
            if (allocated(error)) return
            full = label // " (" // path_name(structured) // ")"
            integ%structured = structured
            call integ%init(sys, 2, 1, 3, status)
            q = q0
            p = p0
            call integ%integrate(sys, q, p, h, steps, status=status)
            call check_status_code(error, status%code, code, full)
            call check(error, all(ieee_is_finite(q)) .and. all(ieee_is_finite(p)), &
                full // ": non-finite state")
            if (code == HOLOSYM_SUCCESS) return
            if (present(text)) then
                call check_mentions(error, status%message, text, full)
            else
                call check_mentions(error, status%message, "use h >= ", full)
                call check_mentions(error, status%message, "resolution", full)
            end if
        end subroutine check_run

    end subroutine tiny_steps

    ! ------------------------------------------------------------------ 8: dependent

    !> A particle moving along the x axis reaches x = 0, from where its two constraints
    !! are the same, at the end of step 8 (h = 1/8 from x = -1). A run that factors its
    !! Newton matrix there (the plain path) stops at step 8 or 9 with
    !! HOLOSYM_RANK_DEFICIENT_CONSTRAINTS (not a singular matrix with a hint about N and
    !! G), keeping the state of the last good step; the fast paths, whose kept factors
    !! solve the consistent equations, may go on along the axis, to the right state.
    subroutine dependent_within_step(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(axis_particle), target :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        integer :: k, done
        character(len=:), allocatable :: label
        sys%n = 3
        sys%m = 2
        do k = 1, 3
            integ = new_integrator()
            integ%structured = k == 1
            label = "into x >= 0 (" // path_name(k == 1) // ")"
            if (k == 3) then
                integ%newton%simplified = .false.
                integ%newton%presolve = .false.
                integ%linear_solver = "real128"
                label = "into x >= 0 (plain path)"
            end if
            call integ%init(sys, 2, 1, 3, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "init")
            q = [-1.0_wp, 0.0_wp, 0.0_wp]
            p = [1.0_wp, 0.0_wp, 0.0_wp]
            call integ%integrate(sys, q, p, 0.125_wp, 16, steps_done=done, status=status)
            if (status%ok() .and. k < 3) then
                call check(error, abs(q(1) - 1) <= 64 * eps .and. &
                    maxval(abs(q(2:))) <= 64 * eps .and. abs(p(1) - 1) <= 64 * eps, &
                    label // ": success at the wrong state x = " // real_str(q(1)))
                cycle
            end if
            call check_status_code(error, status%code, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
                label)
            call check(error, done == 7 .or. done == 8, label // ": steps done " // &
                int_str(done) // ", expected 7 or 8")
            call check(error, abs(q(1) - (done - 8) * 0.125_wp) <= 8 * eps .and. &
                maxval(abs(q(2:))) <= 8 * eps, label // ": state after the last good " // &
                "step: x = " // real_str(q(1)))
            call check_mentions(error, status%message, "rank deficient", label)
            if (allocated(error)) return
            call check(error, index(status%message, "N or G") == 0, label // &
                ": message blames N, G")
        end do
    end subroutine dependent_within_step

    ! ------------------------------------------------------------------ 9: too large

    !> h = 1e30 and h = huge on the pendulum fail with HOLOSYM_STEP_TOO_LARGE: not a
    !! singular matrix blamed on N and G, not a non-finite value blamed on the system's
    !! procedures. (Computes an overflow on purpose: not run where overflow traps.)
    subroutine absurd_steps(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        real(wp) :: q(3), p(3)
        integer :: k
        if (overflow_traps()) then
            call skip(error, "computes an overflow on purpose (h = huge); overflow traps here")
            return
        end if
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        do k = 1, 2
            call check_step_fails(error, sys, q, p, 2, 1.0e30_wp, k == 1, &
                HOLOSYM_STEP_TOO_LARGE, "h = 1e30", "too large", "N or G")
            call check_step_fails(error, sys, q, p, 2, huge(1.0_wp), k == 1, &
                HOLOSYM_STEP_TOO_LARGE, "h = huge", "too large", "returned")
            call check_step_fails(error, sys, q, p, 5, huge(1.0_wp) / 3, k == 1, &
                HOLOSYM_STEP_TOO_LARGE, "h = huge/3, M = 5", "too large", "returned")
        end do
    end subroutine absurd_steps

    ! ------------------------------------------------------------------ 7b: roots

    !> The root check changes no ordinary step: 80 steps of the pendulum at h = 1/8 give
    !! the same bits with and without it, on both paths.
    subroutine ordinary_steps_unchanged(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(constrained_integrator) :: checked, unchecked
        type(holosym_status_t) :: status
        real(wp) :: q1(3), p1(3), q2(3), p2(3)
        integer :: k
        sys = spherical_pendulum()
        do k = 1, 2
            checked = new_integrator()
            unchecked = new_integrator()
            checked%structured = k == 1
            unchecked%structured = k == 1
            unchecked%check_roots = .false.
            call checked%init(sys, 3, 2, 4, status)
            call unchecked%init(sys, 3, 2, 4, status)
            call sys%initial_state(q1, p1)
            q2 = q1
            p2 = p1
            call checked%integrate(sys, q1, p1, 0.125_wp, 80, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "checked run")
            call unchecked%integrate(sys, q2, p2, 0.125_wp, 80, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "unchecked run")
            call check(error, same_bits(q1, q2) .and. same_bits(p1, p2), &
                "the root check changed an ordinary run (" // path_name(k == 1) // ")")
            call check(error, checked%stats%steps == 80 .and. &
                checked%stats%newton_iterations == unchecked%stats%newton_iterations, &
                "the root check did extra Newton work on ordinary steps")
        end do
    end subroutine ordinary_steps_unchanged

    !> The criterion for large steps on one configuration: `steps` steps of h; every step reported
    !! as success has a relative energy error below 1e-2 and (where the run with h/8 of the
    !! same code has reached it) a state within 1e-2 of that run and of 8 steps of h/8 from
    !! its own start; a failure has a positive code, keeps the state and comes after the
    !! first `least` steps.
    subroutine check_criterion(error, sys, q0, p0, order_m, order_n, gauss_points, h, &
                               steps, least, structured, label)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: order_m, order_n, gauss_points, steps
        !> Steps that must succeed: a check that refused resolved steps would fail them.
        integer, intent(in) :: least
        logical, intent(in) :: structured
        character(len=*), intent(in) :: label
        type(constrained_integrator) :: big, small, local
        type(holosym_status_t) :: status
        real(wp) :: q(size(q0)), p(size(p0)), q_before(size(q0)), p_before(size(p0))
        real(wp) :: q_local(size(q0)), p_local(size(p0))
        real(wp) :: q_ref(size(q0), steps), p_ref(size(p0), steps), energy0, energy_error
        real(wp) :: distance
        integer :: k, j, reference_steps
        character(len=:), allocatable :: full
        if (allocated(error)) return
        full = label // " (" // path_name(structured) // ")"
        big%structured = structured
        small%structured = structured
        local%structured = structured
        call big%init(sys, order_m, order_n, gauss_points, status)
        call small%init(sys, order_m, order_n, gauss_points, status)
        call local%init(sys, order_m, order_n, gauss_points, status)
        reference_steps = 0
        q = q0
        p = p0
        reference: do k = 1, steps
            do j = 1, 8
                call small%step(sys, q, p, h / 8, status=status)
                if (.not. status%ok()) exit reference
            end do
            q_ref(:, k) = q
            p_ref(:, k) = p
            reference_steps = k
        end do reference
        q = q0
        p = p0
        energy0 = sys%hamiltonian(q0, p0)
        do k = 1, steps
            q_before = q
            p_before = p
            call big%step(sys, q, p, h, status=status)
            if (.not. status%ok()) then
                call check(error, status%code > 0, full // ": step " // int_str(k) // &
                    " fails with code " // int_str(status%code))
                call check(error, same_bits(q, q_before) .and. same_bits(p, p_before), &
                    full // ": a failed step moved the state")
                call check(error, k > least, full // ": step " // int_str(k) // " refused (" &
                    // status%message // "); the first " // int_str(least) // " are resolved")
                return
            end if
            energy_error = abs((sys%hamiltonian(q, p) - energy0) / energy0)
            call check(error, energy_error < criterion, full // ": step " // int_str(k) // &
                " succeeds with relative energy error " // real_str(energy_error))
            if (k <= reference_steps) then
                distance = max(maxval(abs(q - q_ref(:, k))), maxval(abs(p - p_ref(:, k))))
                call check(error, distance < criterion, full // ": step " // int_str(k) // &
                    " succeeds " // real_str(distance) // " away from the run with h/8")
            end if
            ! The step itself against 8 steps of h/8 from its own start (where they succeed):
            ! a root that is not the flow's continuation lies far from them at any order.
            q_local = q_before
            p_local = p_before
            do j = 1, 8
                call local%step(sys, q_local, p_local, h / 8, status=status)
                if (.not. status%ok()) exit
            end do
            if (status%ok()) then
                distance = max(maxval(abs(q - q_local)), maxval(abs(p - p_local)))
                call check(error, distance < criterion, full // ": step " // int_str(k) // &
                    " succeeds " // real_str(distance) // " away from 8 steps of h/8 " // &
                    "from its start")
            end if
            if (allocated(error)) return
        end do
    end subroutine check_criterion

    !> Magnetic sphere, q(0) = (0.6, 0, 0.8), p(0) = (0, 1.09, 0): (4, 3, 5) at h = 1, where
    !! Newton from the extrapolated guess finds a spurious root at step 2 (energy error
    !! 0.71), and (4, 2, 5) at h = 1/8, with spurious roots at steps 14 and 73 (energy error
    !! 1.43, state 3 away). That scheme (M = N + 2) is ill-conditioned at every h: the run
    !! with h/8 stops at its 122nd step (Newton not converged), so the states are compared
    !! over its first 15 steps of h and, step by step, from each start.
    subroutine spurious_magnetic(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(magnetic_sphere), target :: sys
        real(wp) :: q0(3), p0(3)
        sys%n = 3
        sys%m = 1
        q0 = [0.6_wp, 0.0_wp, 0.8_wp]
        p0 = [0.0_wp, 1.09_wp, 0.0_wp]
        call check_criterion(error, sys, q0, p0, 4, 3, 5, 1.0_wp, 10, 10, .false., &
            "magnetic (4, 3, 5) h = 1")
        call check_criterion(error, sys, q0, p0, 4, 2, 5, 0.125_wp, 40, 15, .false., &
            "magnetic (4, 2, 5) h = 1/8")
    end subroutine spurious_magnetic

    !> Double pendulum (masses 1, 2; rods 1, 0.7; gravity 1; angles 1, -0.5; angular
    !! velocities 0, 0.8) on both paths: (6, 5, 7) at h = 1/4 (a spurious root with energy
    !! error -306 at step 34 on the general path), (8, 7, 9) at h = 1/2 (energy error 8 at
    !! step 8), and (2, 1, 3) at h = 1/4 over 120 steps (-25 at step 114), whose third step
    !! is the flow's own root but does not resolve the motion (3.3e-2 from two steps of h/2,
    !! energy change 1.8e-3): it must fail with a code.
    subroutine spurious_double_pendulum(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain), target :: sys
        real(wp) :: q0(4), p0(4)
        integer :: k
        sys = pendulum_chain(2, masses=[1.0_wp, 2.0_wp], lengths=[1.0_wp, 0.7_wp], &
                             gravity=1.0_wp)
        call sys%state_from_angles([1.0_wp, -0.5_wp], [0.0_wp, 0.8_wp], q0, p0)
        do k = 1, 2
            call check_criterion(error, sys, q0, p0, 6, 5, 7, 0.25_wp, 40, 40, k == 1, &
                "double pendulum (6, 5, 7) h = 1/4")
            call check_criterion(error, sys, q0, p0, 8, 7, 9, 0.5_wp, 15, 15, k == 1, &
                "double pendulum (8, 7, 9) h = 1/2")
            call check_criterion(error, sys, q0, p0, 2, 1, 3, 0.25_wp, 120, 2, k == 1, &
                "double pendulum (2, 1, 3) h = 1/4")
        end do
    end subroutine spurious_double_pendulum

end module test_hardening
