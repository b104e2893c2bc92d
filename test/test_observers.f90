!> Tests of the API around a user's own system, all through `use holosym`: the trajectory
!! writer (the same file as `holosym simulate`, 17 or 36 digits, rows at requested times
!! from the dense output), the energy/constraint monitor, the dense output of the step
!! just taken inside an observer, `state_from_velocities`, and each of them fed bad input
!! (status and message, the caller's data unchanged).
module test_observers
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_positive_inf
    use holosym, only: wp, holosym_status_t, constrained_hamiltonian, constrained_integrator, &
        step_observer, step_info_t, step_dense_output, trajectory_writer, energy_monitor, &
        trajectory_header, state_from_velocities, projection_report_t, manifold_residuals, &
        manifold_tolerance_default, spherical_pendulum, pendulum_chain, magnetic_sphere, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_NOT_INITIALIZED, HOLOSYM_USER_ABORT, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_INVALID_DIMENSION
    use holosym_status_codes, only: int_str, real_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code, &
        split_field
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, &
        scratch_path, read_lines
    implicit none
    private
    public :: observers_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)

    !> Evaluates the dense output in the middle of every step and keeps the last value.
    type, extends(step_observer) :: midpoint_probe
        real(wp) :: q(3) = 0, p(3) = 0, lambda(1) = 0
        integer :: code = -100
        integer :: outside_code = -100
    contains
        procedure :: observe => probe_observe
    end type midpoint_probe

    !> A planar particle whose H does not depend on p_2: d2H/dp2 is singular.
    type, extends(constrained_hamiltonian) :: degenerate_particle
    contains
        procedure :: hamiltonian => degenerate_h
        procedure :: dh_dq => degenerate_dq
        procedure :: dh_dp => degenerate_dp
        procedure :: constraint => degenerate_phi
        procedure :: constraint_jacobian => degenerate_jac
    end type degenerate_particle

contains

    !> The tests of this suite.
    function observers_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("writer_file_equals_simulate", writer_equals_simulate), &
            new_test("writer_17_digits", writer_short_digits), &
            new_test("writer_rows_at_requested_times", writer_interval), &
            new_test("writer_rejects_bad_input", writer_bad_input), &
            new_test("monitor_records_maxima", monitor_maxima), &
            new_test("monitor_rejects_bad_input", monitor_bad_input), &
            new_test("dense_output_inside_observer", dense_inside_observer), &
            new_test("state_from_velocities_consistent", velocities_consistent), &
            new_test("state_from_velocities_rejects_bad_input", velocities_bad_input)]
    end function observers_tests

    !> The writer's file (36 digits, every 4th step, 15 steps: the last row written by
    !! `close`) is the file of `holosym simulate` with the same options, line for line.
    subroutine writer_equals_simulate(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(trajectory_writer) :: writer
        type(holosym_status_t) :: status
        type(command_result_t) :: result
        type(text_line_t), allocatable :: mine(:), theirs(:)
        real(wp) :: q(3), p(3)
        character(len=:), allocatable :: path, cli_path
        integer :: ios, i
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        path = scratch_path("observers_writer.csv")
        cli_path = scratch_path("observers_simulate.csv")
        call integ%init(sys, 2, 1, 3)
        call writer%open(sys, q, p, file=path, every=4, status=status)
        call check(error, status%ok(), "open: " // status%message)
        call integ%integrate(sys, q, p, 0.125_wp, 15, writer, status=status)
        call check(error, status%ok(), "integrate: " // status%message)
        call writer%close(status)
        call check(error, status%ok() .and. writer%rows == 5, "close: " // status%message // &
            ", rows " // int_str(writer%rows))
        call run_holosym("simulate --system pendulum --M 2 --N 1 --G 3 --h 0.125 --steps 15 " &
            // "--every 4 --output " // cli_path, result)
        call check(error, result%exit_code == 0, "holosym simulate failed")
        if (allocated(error)) return
        call read_lines(path, mine, ios)
        call read_lines(cli_path, theirs, ios)
        call check(error, size(mine) == size(theirs) .and. size(mine) == 6, "line counts " // &
            int_str(size(mine)) // " and " // int_str(size(theirs)))
        if (allocated(error)) return
        do i = 1, size(mine)
            call check(error, mine(i)%text == theirs(i)%text, "line " // int_str(i) // &
                " differs: '" // mine(i)%text // "' against '" // theirs(i)%text // "'")
        end do
        call check(error, mine(1)%text == trajectory_header(3, 1), "header")
    end subroutine writer_equals_simulate

    !> digits = 17: every real field has a 17-digit significand; the writer's monitor has
    !! the run's maxima.
    subroutine writer_short_digits(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(trajectory_writer) :: writer
        type(holosym_status_t) :: status
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: path, text
        real(wp) :: q(3), p(3)
        integer :: ios, k, mantissa
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        path = scratch_path("observers_short.csv")
        call integ%init(sys, 2, 1, 3)
        call writer%open(sys, q, p, file=path, digits=17, status=status)
        call integ%integrate(sys, q, p, 0.125_wp, 4, writer, status=status)
        call writer%close(status)
        call read_lines(path, lines, ios)
        call check(error, ios == 0 .and. size(lines) == 6, "5 rows and a header")
        if (allocated(error)) return
        do k = 1, 12
            text = split_field(lines(3)%text, k, ",")
            mantissa = index(text, "E") - 1
            if (text(1:1) == "-") mantissa = mantissa - 1
            ! d.dddddddddddddddd: 17 digits and the point.
            call check(error, mantissa == 18, "field " // int_str(k) // " '" // text // "'")
        end do
        call check(error, writer%monitor%steps == 4 .and. &
            writer%monitor%max_constraint_residual < 1.0e3_wp * eps .and. &
            writer%monitor%max_energy_error > 0, "monitor of the writer")
    end subroutine writer_short_digits

    !> interval = 0.05 with h = 1/8: rows at t = 0.05 k from the dense output (between step
    !! ends) and the steps' own states (at t = 0.5, 1); the dense states agree with a run of
    !! h = 1/80 to the scheme's accuracy.
    subroutine writer_interval(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ, fine
        type(trajectory_writer) :: writer
        type(holosym_status_t) :: status
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: path, field
        real(wp) :: q(3), p(3), qf(3), pf(3), t, value
        integer :: ios, k, i
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        qf = q
        pf = p
        path = scratch_path("observers_interval.csv")
        call integ%init(sys, 3, 2, 4)
        call writer%open(sys, q, p, file=path, interval=0.05_wp, status=status)
        call integ%integrate(sys, q, p, 0.125_wp, 8, writer, status=status)
        call check(error, status%ok(), "integrate: " // status%message)
        call writer%close(status)
        call read_lines(path, lines, ios)
        call check(error, ios == 0 .and. size(lines) == 22, "header and 21 rows (t = 0 .. 1), " &
            // "got " // int_str(size(lines)) // " lines")
        if (allocated(error)) return
        call fine%init(sys, 3, 2, 4)
        do k = 1, 20
            field = split_field(lines(k + 2)%text, 1, ",")
            read (field, *) t
            call check(error, abs(t - 0.05_wp * k) <= 4 * eps, "row time " // field)
            ! The reference at t = 0.05 k: 5 steps of h = 1/100 per row.
            call fine%integrate(sys, qf, pf, 0.01_wp, 5, status=status)
            do i = 1, 3
                field = split_field(lines(k + 2)%text, 1 + i, ",")
                read (field, *) value
                call check(error, abs(value - qf(i)) < 1.0e-7_wp, "q" // int_str(i) // &
                    " at t = " // real_str(t) // ": " // real_str(value) // " against " // &
                    real_str(qf(i)))
            end do
        end do
        call check(error, split_field(lines(22)%text, 2, ",") /= "", "last row")
    end subroutine writer_interval

    !> Bad arguments of open, close without open, integrate with a writer never opened:
    !! each with its code and a message, nothing written.
    subroutine writer_bad_input(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(trajectory_writer) :: writer
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), q_saved(3), p_saved(3)
        character(len=:), allocatable :: path
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        path = scratch_path("observers_bad.csv")
        call writer%open(sys, q, p, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, &
            "neither file nor unit")
        call writer%open(sys, q, p, file=path, unit=6, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "file and unit")
        call writer%open(sys, q, p, file=path, digits=20, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "digits 20")
        call check(error, index(status%message, "20") > 0, "message names 20: " // status%message)
        call writer%open(sys, q, p, file=path, every=0, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "every 0")
        call writer%open(sys, q, p, file=path, interval=-1.0_wp, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "interval -1")
        call writer%open(sys, q(1:2), p, file=path, status=status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "q of size 2")
        call writer%open(sys, q, p, file=scratch_path("no_such_dir/x.csv"), status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "unwritable file")
        call check(error, index(status%message, "no_such_dir") > 0, "message names the file")
        call writer%close(status)
        call check_status_code(error, status%code, HOLOSYM_NOT_INITIALIZED, "close unopened")
        call check(error, writer%rows == 0, "nothing written")
        q_saved = q
        p_saved = p
        call integ%init(sys, 2, 1, 3)
        call integ%integrate(sys, q, p, 0.125_wp, 3, writer, status=status)
        call check_status_code(error, status%code, HOLOSYM_USER_ABORT, "integrate, unopened writer")
        ! The integrator keeps the state of the last good step (the first): the observer
        ! stopped the run after it.
        call check(error, any(q /= q_saved) .or. any(p /= p_saved), "one step taken")
    end subroutine writer_bad_input

    !> The monitor's maxima and iteration counts equal those collected by hand from `step`.
    subroutine monitor_maxima(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain) :: sys
        type(constrained_integrator) :: a, b
        type(energy_monitor) :: monitor
        type(holosym_status_t) :: status
        type(step_info_t) :: info
        real(wp) :: q(4), p(4), qb(4), pb(4), energy0, energy_error, position, velocity
        integer :: k
        sys = pendulum_chain(2, masses=[1.0_wp, 2.0_wp], lengths=[1.0_wp, 0.7_wp])
        call sys%state_from_angles([1.0_wp, 0.5_wp], [0.0_wp, 0.0_wp], q, p)
        qb = q
        pb = p
        call a%init(sys, 2, 1, 3)
        call b%init(sys, 2, 1, 3)
        call monitor%start(sys, q, p, status)
        call check(error, status%ok(), "start: " // status%message)
        call a%integrate(sys, q, p, 0.125_wp, 40, monitor, status=status)
        energy0 = sys%hamiltonian(qb, pb)
        call manifold_residuals(sys, qb, pb, position, velocity)
        energy_error = 0
        do k = 1, 40
            call b%step(sys, qb, pb, 0.125_wp, info)
            energy_error = max(energy_error, abs((sys%hamiltonian(qb, pb) - energy0) / energy0))
            position = max(position, info%constraint_residual)
            velocity = max(velocity, info%velocity_residual)
        end do
        call check(error, monitor%steps == 40, "steps " // int_str(monitor%steps))
        ! integrate sums the increments with compensation, step does not: round-off apart.
        call check(error, abs(monitor%max_energy_error - energy_error) <= 1.0e3_wp * eps, &
            "max energy error " // real_str(monitor%max_energy_error) // &
            " against " // real_str(energy_error))
        call check(error, monitor%max_constraint_residual <= 1.0e3_wp * eps .and. &
            monitor%max_velocity_residual <= 1.0e3_wp * eps, "residuals at round-off")
        ! The steps' iterations; the integrator's stats also count abandoned attempts.
        call check(error, monitor%newton_iterations >= 40 .and. &
            monitor%newton_iterations <= a%stats%newton_iterations, &
            "iterations " // int_str(int(monitor%newton_iterations)) // " against stats")
        call check(error, monitor%max_newton_iterations >= 1 .and. &
            monitor%mean_newton_iterations() > 0, "iteration counts")
    end subroutine monitor_maxima

    !> start with bad sizes or NaN fails and leaves the monitor as it was; a monitor never
    !! started stops the run with a message.
    subroutine monitor_bad_input(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(energy_monitor) :: monitor, fresh
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), nan_q(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call monitor%start(sys, q, p(1:2), status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "p of size 2")
        nan_q = q
        nan_q(2) = ieee_value(1.0_wp, ieee_positive_inf)
        call monitor%start(sys, nan_q, p, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "q with Inf")
        call check(error, monitor%steps == fresh%steps .and. &
            monitor%initial_energy == fresh%initial_energy, "monitor unchanged")
        call integ%init(sys, 2, 1, 3)
        call integ%integrate(sys, q, p, 0.125_wp, 2, monitor, status=status)
        call check_status_code(error, status%code, HOLOSYM_USER_ABORT, "monitor not started")
        call check(error, index(monitor%message, "start") > 0, "message: " // monitor%message)
    end subroutine monitor_bad_input

    !> Inside observe, `self%dense` evaluates the step just taken: in the middle of a step it
    !! equals `dense_output(0.5)` after that step; outside the step it fails; after
    !! `integrate` it is unavailable.
    subroutine dense_inside_observer(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(midpoint_probe) :: probe
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), qd(3), pd(3), lambda(1), q_saved(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call integ%init(sys, 3, 2, 4)
        call integ%integrate(sys, q, p, 0.125_wp, 5, probe, status=status)
        call check(error, status%ok() .and. probe%code == HOLOSYM_SUCCESS, &
            "evaluate inside observe")
        call integ%dense_output(0.5_wp, qd, pd, lambda)
        call check(error, all(abs(probe%q - qd) <= 4 * eps) .and. &
            all(abs(probe%p - pd) <= 4 * eps) .and. all(abs(probe%lambda - lambda) <= 16 * eps), &
            "the step just taken")
        call check_status_code(error, probe%outside_code, HOLOSYM_INVALID_ARGUMENT, &
            "t beyond the step")
        call check(error, .not. probe%dense%available(), "unavailable after integrate")
        q_saved = q
        call probe%dense%evaluate(0.0_wp, q, p, lambda, status)
        call check_status_code(error, status%code, HOLOSYM_NOT_INITIALIZED, "outside integrate")
        call check(error, all(q == q_saved), "q unchanged on failure")
    end subroutine dense_inside_observer

    subroutine probe_observe(self, step, t, q, p, info, halt)
        class(midpoint_probe), intent(inout) :: self
        integer, intent(in) :: step
        real(wp), intent(in) :: t, q(:), p(:)
        type(step_info_t), intent(in) :: info
        logical, intent(inout) :: halt
        type(holosym_status_t) :: status
        real(wp) :: qx(3), px(3), lx(1)
        call self%dense%evaluate((self%dense%t_start + self%dense%t_end) / 2, self%q, self%p, &
                                 self%lambda, status)
        self%code = status%code
        call self%dense%evaluate(t + 1, qx, px, lx, status)
        self%outside_code = status%code
    end subroutine probe_observe

    !> Double pendulum: exact positions and tangent velocities give p = M q' to round-off;
    !! positions off by 1e-6 and velocities with a normal part give a state the integrator
    !! accepts. Magnetic particle: p = mass q' + A(q) (H not separable).
    subroutine velocities_consistent(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain) :: chain
        type(magnetic_sphere) :: magnetic
        type(holosym_status_t) :: status
        type(projection_report_t) :: report
        real(wp) :: q(4), p(4), qdot(4), q_exact(4), p_exact(4), position, velocity
        real(wp) :: sp, sv, qm(3), pm(3), vm(3)
        chain = pendulum_chain(2, masses=[1.0_wp, 2.0_wp], lengths=[1.0_wp, 0.7_wp])
        call chain%state_from_angles([1.0_wp, 0.5_wp], [0.3_wp, -0.2_wp], q_exact, p_exact)
        qdot = p_exact / [1.0_wp, 1.0_wp, 2.0_wp, 2.0_wp]
        q = q_exact
        p = 0
        call state_from_velocities(chain, q, qdot, p, status)
        call check(error, status%ok(), "exact state: " // status%message)
        call check(error, maxval(abs(p - p_exact)) <= 64 * eps .and. &
            maxval(abs(q - q_exact)) <= 4 * eps, "p = M q' for a consistent input")
        q = q_exact + 1.0e-6_wp * [1.0_wp, -1.0_wp, 0.5_wp, 2.0_wp]
        qdot = qdot + 0.1_wp * q_exact
        call state_from_velocities(chain, q, qdot, p, status, report=report)
        call check(error, status%ok(), "perturbed state: " // status%message)
        call manifold_residuals(chain, q, p, position, velocity, sp, sv)
        call check(error, sp <= manifold_tolerance_default .and. &
            sv <= manifold_tolerance_default, "projected state accepted: " // real_str(sp) // &
            ", " // real_str(sv))
        call check(error, report%position_iterations >= 1 .and. report%momentum_iterations >= 1, &
            "both stages worked")
        magnetic = magnetic_sphere()
        call magnetic%initial_state(qm, pm)
        vm = (pm - magnetic%vector_potential(qm)) / magnetic%mass
        p = 0
        call state_from_velocities(magnetic, qm, vm, pm, status)
        call check(error, status%ok(), "magnetic: " // status%message)
        call check(error, maxval(abs(pm - (magnetic%mass * vm + magnetic%vector_potential(qm)))) &
            <= 64 * eps, "magnetic: p = mass v + A(q)")
    end subroutine velocities_consistent

    !> Sizes, NaN, a degenerate d2H/dp2, bad dimensions: codes, messages, q and p unchanged.
    subroutine velocities_bad_input(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(degenerate_particle) :: degenerate
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), v(3), q2(2), p2(2), v2(2), q_saved(3), p_saved(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        v = p
        q_saved = q
        p_saved = p
        call state_from_velocities(sys, q, v(1:2), p, status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "velocity of size 2")
        v(3) = ieee_value(1.0_wp, ieee_positive_inf)
        call state_from_velocities(sys, q, v, p, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "Inf velocity")
        call check(error, index(status%message, "velocity") > 0, "message: " // status%message)
        call check(error, all(q == q_saved) .and. all(p == p_saved), "q, p unchanged")
        degenerate%n = 2
        degenerate%m = 1
        q2 = [0.6_wp, 0.8_wp]
        v2 = [0.8_wp, -0.6_wp]
        p2 = 7
        call state_from_velocities(degenerate, q2, v2, p2, status)
        call check_status_code(error, status%code, HOLOSYM_SINGULAR_MATRIX, "d2H/dp2 singular")
        call check(error, all(p2 == 7) .and. q2(1) == 0.6_wp, "q, p unchanged")
        degenerate%m = 2
        call state_from_velocities(degenerate, q2, v2, p2, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_DIMENSION, "m = n")
    end subroutine velocities_bad_input

    function degenerate_h(self, q, p) result(energy)
        class(degenerate_particle), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = p(1)**2 / 2 + q(2)
    end function degenerate_h

    subroutine degenerate_dq(self, q, p, gradient)
        class(degenerate_particle), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = [0.0_wp, 1.0_wp]
    end subroutine degenerate_dq

    subroutine degenerate_dp(self, q, p, gradient)
        class(degenerate_particle), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = [p(1), 0.0_wp]
    end subroutine degenerate_dp

    subroutine degenerate_phi(self, q, phi)
        class(degenerate_particle), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi(1) = sum(q**2) - 1
    end subroutine degenerate_phi

    subroutine degenerate_jac(self, q, jacobian)
        class(degenerate_particle), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian(1, :) = 2 * q
    end subroutine degenerate_jac

end module test_observers
