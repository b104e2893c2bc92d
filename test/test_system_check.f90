!> Tests of the check of a user's system (holosym_system_check, the integrator's
!! `check_system` setting): every built-in system and model file passes it, and each kind
!! of wrong procedure or declaration is refused with HOLOSYM_INCONSISTENT_SYSTEM naming it
!! (a mass that does not match dh_dp, a sparsity that leaves out a nonzero, a Jacobian
!! wrong in one entry, a wrong or zero Hessian, a wrong gradient, a potential pattern that
!! leaves out a coupling, a wrong real64 gradient, procedures at many points that disagree
!! with those of one point) instead of a wrong trajectory; procedures at many points that
!! agree are used by the step.
module test_system_check
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INCONSISTENT_SYSTEM
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_system_check, only: check_system, system_check_report_t
    use holosym_models, only: spherical_pendulum, planar_pendulum
    use holosym_model_generic, only: generic_pendulum
    use holosym_formula_model, only: formula_model, load_model
    use holosym_test_systems, only: builtin_system
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    use holosym_test_commands, only: command_result_t, run_holosym, any_line_contains
    implicit none
    private
    public :: system_check_tests

    !> A spherical pendulum of mass 2 that declares mass 1.
    type, extends(spherical_pendulum) :: wrong_mass_pendulum
    contains
        procedure :: diagonal_mass => one_mass
    end type wrong_mass_pendulum

    !> A planar pendulum whose declared Phi pattern leaves out d phi / d y.
    type, extends(planar_pendulum) :: short_pattern_pendulum
    contains
        procedure :: constraint_sparsity => x_only_pattern
        procedure :: constraint_jacobian_values => x_only_values
    end type short_pattern_pendulum

    !> A planar pendulum whose Jacobian is wrong by 1e-3 in one entry.
    type, extends(planar_pendulum) :: wrong_jacobian_pendulum
    contains
        procedure :: constraint_jacobian => off_jacobian
    end type wrong_jacobian_pendulum

    !> A planar pendulum whose constraint Hessian is zero.
    type, extends(planar_pendulum) :: zero_hessian_pendulum
    contains
        procedure :: constraint_hessian => zero_constraint_hessian
    end type zero_hessian_pendulum

    !> A planar pendulum whose dh_dq has the wrong sign.
    type, extends(planar_pendulum) :: wrong_gradient_pendulum
    contains
        procedure :: dh_dq => negated_dh_dq
    end type wrong_gradient_pendulum

    !> A generic pendulum whose hessian leaves out d2H/dx dy.
    type, extends(generic_pendulum) :: wrong_hessian_pendulum
    contains
        procedure :: hessian => diagonal_hessian
    end type wrong_hessian_pendulum

    !> A generic pendulum (dense Hessian of U) declaring a potential with no couplings.
    type, extends(generic_pendulum) :: short_potential_pendulum
    contains
        procedure :: potential_sparsity => diagonal_potential
        procedure :: constraint_sparsity => sphere_pattern
    end type short_potential_pendulum

    !> A spherical pendulum whose real64 gradient is off.
    type, extends(spherical_pendulum) :: wrong_double_pendulum
    contains
        procedure :: dh_dq_double => doubled_dh_dq
    end type wrong_double_pendulum

    !> A spherical pendulum with its own procedures at many points, the formulas of one
    !! point applied to every column (they count their calls: `batched_calls`).
    type, extends(spherical_pendulum) :: batched_pendulum
    contains
        procedure :: dh_dq_points => batched_dh_dq
        procedure :: dh_dq_double_points => batched_dh_dq_double
        procedure :: constraint_points => batched_constraint
        procedure :: constraint_jacobian_values_points => batched_values
    end type batched_pendulum

    !> A spherical pendulum whose dh_dq_points gives every point the first point's value.
    type, extends(spherical_pendulum) :: first_point_pendulum
    contains
        procedure :: dh_dq_points => first_point_dh_dq
    end type first_point_pendulum

    !> A spherical pendulum whose constraint_points leaves out the last point.
    type, extends(spherical_pendulum) :: short_constraint_pendulum
    contains
        procedure :: constraint_points => short_constraint
    end type short_constraint_pendulum

    !> Calls of the batched_pendulum's procedures at many points.
    integer :: batched_calls = 0

contains

    !> The tests of this suite.
    function system_check_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("builtin_systems_pass", builtin_pass), &
            new_test("model_files_pass", models_pass), &
            new_test("refuses_a_wrong_mass", wrong_mass), &
            new_test("refuses_a_pattern_that_leaves_out_a_nonzero", short_pattern), &
            new_test("refuses_a_jacobian_wrong_in_one_entry", wrong_jacobian), &
            new_test("refuses_a_zero_constraint_hessian", zero_hessian), &
            new_test("refuses_a_wrong_gradient", wrong_gradient), &
            new_test("refuses_a_wrong_hessian", wrong_hessian), &
            new_test("refuses_a_potential_pattern_that_leaves_out_a_coupling", &
                     short_potential), &
            new_test("refuses_a_wrong_real64_gradient", wrong_double), &
            new_test("refuses_procedures_at_many_points_that_disagree", wrong_points), &
            new_test("uses_procedures_at_many_points_that_agree", batched_used), &
            new_test("can_be_switched_off", switched_off), &
            new_test("holosym_check_command", check_command_runs)]
    end function system_check_tests

    ! ---------------------------------------------------------------- wrong systems

    logical function one_mass(self, mass) result(declared)
        class(wrong_mass_pendulum), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass = 1
        declared = .true.
    end function one_mass

    subroutine x_only_pattern(self, rows, columns)
        class(short_pattern_pendulum), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        rows = [1]
        columns = [1]
    end subroutine x_only_pattern

    subroutine x_only_values(self, q, rows, columns, values)
        class(short_pattern_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(out) :: values(:)
        values(1) = 2 * q(1)
    end subroutine x_only_values

    subroutine off_jacobian(self, q, jacobian)
        class(wrong_jacobian_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian(1, :) = 2 * q
        jacobian(1, 2) = jacobian(1, 2) * (1 + 1.0e-3_wp)
    end subroutine off_jacobian

    subroutine zero_constraint_hessian(self, q, hessian)
        class(zero_hessian_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        hessian = 0
    end subroutine zero_constraint_hessian

    subroutine negated_dh_dq(self, q, p, gradient)
        class(wrong_gradient_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = [0.0_wp, -1.0_wp]
    end subroutine negated_dh_dq

    subroutine diagonal_hessian(self, q, p, hqq, hqp, hpp)
        class(wrong_hessian_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        call self%generic_pendulum%hessian(q, p, hqq, hqp, hpp)
        hqq(1, 2) = 0
        hqq(2, 1) = 0
    end subroutine diagonal_hessian

    subroutine diagonal_potential(self, rows, columns)
        class(short_potential_pendulum), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        rows = [1, 2, 3]
        columns = [1, 2, 3]
    end subroutine diagonal_potential

    subroutine sphere_pattern(self, rows, columns)
        class(short_potential_pendulum), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        rows = [1, 1, 1]
        columns = [1, 2, 3]
    end subroutine sphere_pattern

    subroutine doubled_dh_dq(self, q, p, gradient)
        class(wrong_double_pendulum), intent(in) :: self
        real(dp), intent(in) :: q(:), p(:)
        real(dp), intent(out) :: gradient(:)
        gradient = [0.0_dp, 0.0_dp, -2 * cos(q(3))]
    end subroutine doubled_dh_dq

    subroutine batched_dh_dq(self, q, p, gradients)
        class(batched_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:, :), p(:, :)
        real(wp), intent(out) :: gradients(:, :)
        batched_calls = batched_calls + 1
        gradients(1:2, :) = 0
        gradients(3, :) = -self%mass * cos(q(3, :))
    end subroutine batched_dh_dq

    subroutine batched_dh_dq_double(self, q, p, gradients)
        class(batched_pendulum), intent(in) :: self
        real(dp), intent(in) :: q(:, :), p(:, :)
        real(dp), intent(out) :: gradients(:, :)
        batched_calls = batched_calls + 1
        gradients(1:2, :) = 0
        gradients(3, :) = -real(self%mass, dp) * cos(q(3, :))
    end subroutine batched_dh_dq_double

    subroutine batched_constraint(self, q, phi)
        class(batched_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:, :)
        real(wp), intent(out) :: phi(:, :)
        batched_calls = batched_calls + 1
        phi(1, :) = sum(q**2, dim=1) - self%length**2
    end subroutine batched_constraint

    subroutine batched_values(self, q, rows, columns, values)
        class(batched_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:, :)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(out) :: values(:, :)
        integer :: e
        batched_calls = batched_calls + 1
        do e = 1, size(rows)
            values(e, :) = 2 * q(columns(e), :)
        end do
    end subroutine batched_values

    subroutine first_point_dh_dq(self, q, p, gradients)
        class(first_point_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:, :), p(:, :)
        real(wp), intent(out) :: gradients(:, :)
        integer :: j
        do j = 1, size(q, 2)
            call self%dh_dq(q(:, 1), p(:, 1), gradients(:, j))
        end do
    end subroutine first_point_dh_dq

    subroutine short_constraint(self, q, phi)
        class(short_constraint_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:, :)
        real(wp), intent(out) :: phi(:, :)
        integer :: j
        phi = 0
        do j = 1, size(q, 2) - 1
            call self%constraint(q(:, j), phi(:, j))
        end do
    end subroutine short_constraint

    ! ---------------------------------------------------------------- helpers

    !> A step of `sys` from (q, p) must fail with HOLOSYM_INCONSISTENT_SYSTEM and a message
    !! holding `names`, and leave q and p unchanged.
    subroutine expect_refusal(error, sys, q, p, names)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        character(len=*), intent(in) :: names
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: qs(size(q)), ps(size(p))
        qs = q
        ps = p
        call integ%init(sys, 2, 1, 3, status)
        call check(error, status%ok(), "init: " // status%message)
        if (allocated(error)) return
        call integ%step(sys, qs, ps, 0.125_wp, status=status)
        call check_status_code(error, status%code, HOLOSYM_INCONSISTENT_SYSTEM, &
            names // ": " // status%message)
        if (allocated(error)) return
        call check(error, index(status%message, names) > 0, "the message names " // names // &
            ": " // status%message)
        if (allocated(error)) return
        call check(error, all(qs == q) .and. all(ps == p), "q and p unchanged")
    end subroutine expect_refusal

    ! ---------------------------------------------------------------- tests

    !> Every built-in system passes the check at its start.
    subroutine builtin_pass(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: names(*) = [character(len=10) :: "pendulum", &
            "linkage", "planar", "double", "chain4", "dumbbell", "magnetic", "generic"]
        class(constrained_hamiltonian), allocatable :: sys
        type(system_check_report_t) :: report
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:)
        integer :: k
        do k = 1, size(names)
            call builtin_system(trim(names(k)), sys, q, p)
            call check_system(sys, q, p, report, status)
            call check(error, status%ok() .and. report%passed(), trim(names(k)) // ": " // &
                status%message)
            if (allocated(error)) return
        end do
    end subroutine builtin_pass

    !> Every model file of example/models passes the check at its start.
    subroutine models_pass(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: files(*) = [character(len=24) :: "spherical_pendulum", &
            "spring_linkage", "planar_pendulum", "double_pendulum", "sphere_dumbbell", &
            "magnetic_sphere", "generic_pendulum", "water", "fourbar", "chain8"]
        type(formula_model) :: model
        type(system_check_report_t) :: report
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:)
        integer :: k
        do k = 1, size(files)
            call load_model("example/models/" // trim(files(k)) // ".hsm", model, status)
            allocate (q(model%n), p(model%n))
            call model%initial_state(q, p, status)
            call check_system(model, q, p, report, status)
            call check(error, status%ok(), trim(files(k)) // ": " // status%message)
            if (allocated(error)) return
            deallocate (q, p)
        end do
    end subroutine models_pass

    subroutine wrong_mass(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(wrong_mass_pendulum) :: sys
        real(wp) :: q(3), p(3)
        sys%spherical_pendulum = spherical_pendulum(mass=2.0_wp)
        call sys%initial_state(q, p)
        call expect_refusal(error, sys, q, p, "diagonal_mass and dh_dp")
    end subroutine wrong_mass

    !> d phi / d y left out, started at rest at x = 0 (where d phi / d x vanishes too).
    subroutine short_pattern(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(short_pattern_pendulum) :: sys
        sys%planar_pendulum = planar_pendulum()
        call expect_refusal(error, sys, [0.0_wp, -1.0_wp], [0.0_wp, 0.0_wp], &
            "constraint_sparsity and constraint_jacobian differ")
        if (allocated(error)) return
        call expect_refusal(error, sys, [0.0_wp, -1.0_wp], [0.0_wp, 0.0_wp], &
            "entry (1, 2) left out")
    end subroutine short_pattern

    subroutine wrong_jacobian(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(wrong_jacobian_pendulum) :: sys
        real(wp) :: q(2), p(2)
        sys%planar_pendulum = planar_pendulum()
        call sys%initial_state(q, p)
        call expect_refusal(error, sys, q, p, "constraint_jacobian and differences of " // &
            "constraint")
    end subroutine wrong_jacobian

    subroutine zero_hessian(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(zero_hessian_pendulum) :: sys
        real(wp) :: q(2), p(2)
        sys%planar_pendulum = planar_pendulum()
        call sys%initial_state(q, p)
        call expect_refusal(error, sys, q, p, "constraint_hessian and differences")
    end subroutine zero_hessian

    subroutine wrong_gradient(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(wrong_gradient_pendulum) :: sys
        real(wp) :: q(2), p(2)
        sys%planar_pendulum = planar_pendulum()
        call sys%initial_state(q, p)
        call expect_refusal(error, sys, q, p, "dh_dq and differences of hamiltonian")
    end subroutine wrong_gradient

    subroutine wrong_hessian(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(wrong_hessian_pendulum) :: sys
        real(wp) :: q(3), p(3)
        sys%generic_pendulum = generic_pendulum()
        call sys%initial_state(q, p)
        call expect_refusal(error, sys, q, p, "hessian and differences of dh_dq, dh_dp")
    end subroutine wrong_hessian

    subroutine short_potential(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(short_potential_pendulum) :: sys
        real(wp) :: q(3), p(3)
        sys%generic_pendulum = generic_pendulum()
        call sys%initial_state(q, p)
        call expect_refusal(error, sys, q, p, "potential_sparsity and differences of dh_dq")
    end subroutine short_potential

    subroutine wrong_double(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(wrong_double_pendulum) :: sys
        real(wp) :: q(3), p(3)
        sys%spherical_pendulum = spherical_pendulum()
        call sys%initial_state(q, p)
        call expect_refusal(error, sys, q, p, "dh_dq_double and dh_dq")
    end subroutine wrong_double

    !> A batched procedure that ignores the column, or one that leaves out a point, is
    !! refused by name (at the start, away from where the columns agree by chance).
    subroutine wrong_points(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(first_point_pendulum) :: first
        type(short_constraint_pendulum) :: short
        real(wp) :: q(3), p(3)
        first%spherical_pendulum = spherical_pendulum()
        call first%initial_state(q, p)
        call expect_refusal(error, first, q, p, "dh_dq_points and dh_dq")
        if (allocated(error)) return
        short%spherical_pendulum = spherical_pendulum()
        call expect_refusal(error, short, q, p, "constraint_points and constraint")
    end subroutine wrong_points

    !> Procedures at many points that agree with those of one point pass the check, are
    !! what the step calls, and give the trajectory of the pendulum without them (the same
    !! formulas: to round-off).
    subroutine batched_used(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(batched_pendulum) :: batched
        type(spherical_pendulum) :: plain
        type(constrained_integrator) :: a, b
        type(holosym_status_t) :: status
        type(system_check_report_t) :: report
        real(wp) :: qa(3), pa(3), qb(3), pb(3)
        integer :: k
        batched%spherical_pendulum = spherical_pendulum()
        plain = spherical_pendulum()
        call plain%initial_state(qa, pa)
        qb = qa
        pb = pa
        call check_system(batched, qb, pb, report, status)
        call check(error, status%ok() .and. report%passed(), "check: " // status%message)
        if (allocated(error)) return
        call a%init(plain, 4, 3, 5, status)
        call b%init(batched, 4, 3, 5, status)
        batched_calls = 0
        do k = 1, 20
            call a%step(plain, qa, pa, 0.25_wp, status=status)
            call check(error, status%ok(), "plain step: " // status%message)
            if (allocated(error)) return
            call b%step(batched, qb, pb, 0.25_wp, status=status)
            call check(error, status%ok(), "batched step: " // status%message)
            if (allocated(error)) return
        end do
        call check(error, batched_calls >= 3 * 20, "the steps called the procedures at " // &
            "many points: " // int_str(batched_calls) // " calls in 20 steps")
        if (allocated(error)) return
        call check(error, maxval(abs(qa - qb)) + maxval(abs(pa - pb)) <= 100 * epsilon(1.0_wp), &
            "the same trajectory to round-off")
    end subroutine batched_used

    !> With `check_system = .false.` the same wrong mass is taken as declared (the step
    !! succeeds): the check, not the scheme, refuses it.
    subroutine switched_off(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(wrong_mass_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        sys%spherical_pendulum = spherical_pendulum(mass=2.0_wp)
        call sys%initial_state(q, p)
        integ%check_system = .false.
        call integ%init(sys, 2, 1, 3, status)
        call integ%step(sys, q, p, 0.125_wp, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
    end subroutine switched_off

    !> `holosym check` prints the table and the verdict for built-in systems and model
    !! files (exit 0), and refuses bad usage (exit 2).
    subroutine check_command_runs(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=48), parameter :: lines(*) = [character(len=48) :: &
            "check --system dumbbell", "check --system chain --links 12", &
            "check --model example/models/fourbar.hsm", &
            "check --model example/models/water.hsm --set k=2"]
        integer :: k
        do k = 1, size(lines)
            call run_holosym(trim(lines(k)), result)
            call check(error, result%exit_code == 0 .and. any_line_contains(result%out, &
                "Verdict: every comparison made passed.") .and. any_line_contains(result%out, &
                "| constraint_jacobian and differences of constraint |"), trim(lines(k)) // &
                ": exit " // int_str(result%exit_code))
            if (allocated(error)) return
        end do
        call run_holosym("check --system pendulum --model example/models/water.hsm", result)
        call check(error, result%exit_code == 2, "--system with --model: exit 2")
        if (allocated(error)) return
        call run_holosym("check --frobnicate", result)
        call check(error, result%exit_code == 2 .and. any_line_contains(result%err, &
            "unknown option '--frobnicate'"), "an unknown option: exit 2")
    end subroutine check_command_runs

end module test_system_check
