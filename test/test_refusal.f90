!> Tests of a user's procedure refusing a point (`self%refuse(reason)`): a step that meets
!! a refused point fails with HOLOSYM_OUTSIDE_DOMAIN and the system's reason, on both
!! paths, with the caller's state and the last step unchanged and nothing non-finite
!! anywhere; at the start state (`step`, `project_to_manifold`, `check_system`); a
!! refusal outside any call of the library does not fail the next one.
module test_refusal
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
    use holosym, only: wp, holosym_status_t, constrained_hamiltonian, constrained_integrator, &
        step_info_t, project_to_manifold, check_system, system_check_report_t, &
        HOLOSYM_SUCCESS, HOLOSYM_OUTSIDE_DOMAIN
    use holosym_status_codes, only: real_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: refusal_tests

    !> A point mass on the unit circle in uniform gravity (n = 2, m = 1) whose procedures
    !! are defined only below the height `limit`: above it every one of them refuses.
    !! With `nan_values` a refusing procedure returns NaN instead of finite values.
    type, extends(constrained_hamiltonian) :: bounded_pendulum
        real(wp) :: limit = 0.5_wp
        logical :: nan_values = .false.
    contains
        procedure :: hamiltonian => bounded_h
        procedure :: dh_dq => bounded_dq
        procedure :: dh_dp => bounded_dp
        procedure :: constraint => bounded_phi
        procedure :: constraint_jacobian => bounded_jac
        procedure :: diagonal_mass => bounded_mass
        procedure :: outside => bounded_outside
    end type bounded_pendulum

contains

    !> The tests of this suite.
    function refusal_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("refused_step_reduced_path", refused_reduced), &
            new_test("refused_step_general_path", refused_general), &
            new_test("refusal_wins_over_nan_values", refusal_over_nan), &
            new_test("refused_start_state", refused_start), &
            new_test("lifted_refusal_steps_again", lifted_refusal), &
            new_test("refusal_outside_a_call_forgotten", stale_refusal), &
            new_test("projection_refused", projection_refused), &
            new_test("check_system_refused", check_refused)]
    end function refusal_tests

    !> The bottom of the circle with the momentum that swings the mass to y = 0.805, above
    !! the default limit 0.5.
    subroutine swing_state(q, p)
        real(wp), intent(out) :: q(2), p(2)
        q = [0.0_wp, -1.0_wp]
        p = [1.9_wp, 0.0_wp]
    end subroutine swing_state

    function new_bounded(n, m) result(sys)
        integer, intent(in) :: n, m
        type(bounded_pendulum) :: sys
        sys%n = n
        sys%m = m
    end function new_bounded

    !> Integrate 200 steps of h = 1/16 from `swing_state` on the chosen path: the run stops
    !! with HOLOSYM_OUTSIDE_DOMAIN and the system's reason after k < 200 steps, with the
    !! state of exactly k steps of a fresh run, finite, below the limit, and the last
    !! step's information that of step k.
    subroutine refused_run(error, structured, nan_values)
        type(test_error_t), allocatable, intent(out) :: error
        logical, intent(in) :: structured, nan_values
        type(bounded_pendulum) :: sys
        type(constrained_integrator) :: integ, fresh
        type(holosym_status_t) :: status
        type(step_info_t) :: before, after
        real(wp) :: q(2), p(2), q_ref(2), p_ref(2), h
        integer :: done, done_ref
        sys = new_bounded(2, 1)
        sys%nan_values = nan_values
        h = 1.0_wp / 16
        call swing_state(q, p)
        integ%structured = structured
        call integ%init(sys, 3, 2, 4, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "init")
        if (allocated(error)) return
        call integ%integrate(sys, q, p, h, 200, steps_done=done, status=status)
        call check_status_code(error, status%code, HOLOSYM_OUTSIDE_DOMAIN, "integrate")
        if (allocated(error)) return
        call check(error, index(status%message, "above the limit") > 0 .and. &
            index(status%message, "refused") > 0, "the reason in the message: " // &
            status%message)
        if (allocated(error)) return
        call check(error, done > 1 .and. done < 200, "stops within the run")
        if (allocated(error)) return
        call check(error, all(ieee_is_finite(q)) .and. all(ieee_is_finite(p)) .and. &
            q(2) <= sys%limit, "the state is finite and inside the domain")
        if (allocated(error)) return
        before = integ%last_step()
        call swing_state(q_ref, p_ref)
        fresh%structured = structured
        call fresh%init(sys, 3, 2, 4)
        call fresh%integrate(sys, q_ref, p_ref, h, done, steps_done=done_ref, status=status)
        call check(error, status%ok() .and. done_ref == done, "a fresh run of k steps")
        if (allocated(error)) return
        call check(error, all(q == q_ref) .and. all(p == p_ref), &
            "the state is that of the last accepted step")
        if (allocated(error)) return
        after = fresh%last_step()
        call check(error, before%newton_iterations == after%newton_iterations .and. &
            all(before%lambda == after%lambda), &
            "the last step is the last accepted one")
    end subroutine refused_run

    subroutine refused_reduced(error)
        type(test_error_t), allocatable, intent(out) :: error
        call refused_run(error, .true., .false.)
    end subroutine refused_reduced

    subroutine refused_general(error)
        type(test_error_t), allocatable, intent(out) :: error
        call refused_run(error, .false., .false.)
    end subroutine refused_general

    !> A procedure that refuses and returns NaN: the refusal is the outcome, on both paths.
    subroutine refusal_over_nan(error)
        type(test_error_t), allocatable, intent(out) :: error
        call refused_run(error, .true., .true.)
        if (allocated(error)) return
        call refused_run(error, .false., .true.)
    end subroutine refusal_over_nan

    !> A start state above the limit: `step` fails at the start with the reason, q and p
    !! unchanged.
    subroutine refused_start(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(bounded_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2), q0(2), p0(2)
        sys = new_bounded(2, 1)
        q0 = [0.6_wp, 0.8_wp]
        p0 = [0.0_wp, 0.0_wp]
        q = q0
        p = p0
        call integ%init(sys, 3, 2, 4)
        call integ%step(sys, q, p, 0.0625_wp, status=status)
        call check_status_code(error, status%code, HOLOSYM_OUTSIDE_DOMAIN, "step")
        if (allocated(error)) return
        call check(error, index(status%message, "at the start state") > 0 .and. &
            index(status%message, "above the limit") > 0, "message: " // status%message)
        if (allocated(error)) return
        call check(error, all(q == q0) .and. all(p == p0), "state unchanged")
    end subroutine refused_start

    !> After a refused step the same integrator continues once the domain allows it: the
    !! refusal is not kept.
    subroutine lifted_refusal(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(bounded_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2)
        integer :: done
        sys = new_bounded(2, 1)
        call swing_state(q, p)
        call integ%init(sys, 3, 2, 4)
        call integ%integrate(sys, q, p, 0.0625_wp, 200, steps_done=done, status=status)
        call check_status_code(error, status%code, HOLOSYM_OUTSIDE_DOMAIN, "integrate")
        if (allocated(error)) return
        sys%limit = 2
        call integ%integrate(sys, q, p, 0.0625_wp, 200 - done, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "the rest of the run")
    end subroutine lifted_refusal

    !> The user calls a procedure at a refused point outside the library: the next step
    !! (at a good point) succeeds.
    subroutine stale_refusal(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(bounded_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2), energy
        sys = new_bounded(2, 1)
        energy = sys%hamiltonian([0.6_wp, 0.8_wp], [0.0_wp, 0.0_wp])
        call swing_state(q, p)
        call integ%init(sys, 3, 2, 4)
        call integ%step(sys, q, p, 0.0625_wp, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "step after a refusal " // &
            "outside the library (H = " // real_str(energy) // ")")
    end subroutine stale_refusal

    !> `project_to_manifold` from a state above the limit: code, reason, q and p unchanged.
    subroutine projection_refused(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(bounded_pendulum) :: sys
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2), q0(2), p0(2)
        sys = new_bounded(2, 1)
        q0 = [0.7_wp, 0.75_wp]
        p0 = [0.1_wp, 0.2_wp]
        q = q0
        p = p0
        call project_to_manifold(sys, q, p, status)
        call check_status_code(error, status%code, HOLOSYM_OUTSIDE_DOMAIN, "project")
        if (allocated(error)) return
        call check(error, index(status%message, "above the limit") > 0, "message: " // &
            status%message)
        if (allocated(error)) return
        call check(error, all(q == q0) .and. all(p == p0), "state unchanged")
    end subroutine projection_refused

    !> `check_system` at a refused state: the refusal, not an inconsistency.
    subroutine check_refused(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(bounded_pendulum) :: sys
        type(system_check_report_t) :: report
        type(holosym_status_t) :: status
        sys = new_bounded(2, 1)
        call check_system(sys, [0.6_wp, 0.8_wp], [0.1_wp, -0.075_wp], report, status)
        call check_status_code(error, status%code, HOLOSYM_OUTSIDE_DOMAIN, "check_system")
        if (allocated(error)) return
        call check_system(sys, [0.6_wp, -0.8_wp], [0.1_wp, 0.075_wp], report, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "check_system inside")
    end subroutine check_refused

    ! ------------------------------------------------------------ the bounded pendulum

    !> Whether q lies above the limit; if so, refuse it. `value` is what a refusing
    !! procedure returns (0, or NaN with `nan_values`).
    logical function bounded_outside(self, q, value) result(outside)
        class(bounded_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: value
        outside = q(2) > self%limit
        value = 0
        if (.not. outside) return
        call self%refuse("height y = " // real_str(q(2)) // " above the limit " // &
            real_str(self%limit))
        if (self%nan_values) value = ieee_value(1.0_wp, ieee_quiet_nan)
    end function bounded_outside

    function bounded_h(self, q, p) result(energy)
        class(bounded_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        if (self%outside(q, energy)) return
        energy = sum(p**2) / 2 + q(2)
    end function bounded_h

    subroutine bounded_dq(self, q, p, gradient)
        class(bounded_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        real(wp) :: value
        if (self%outside(q, value)) then
            gradient = value
            return
        end if
        gradient = [0.0_wp, 1.0_wp] + 0 * p
    end subroutine bounded_dq

    subroutine bounded_dp(self, q, p, gradient)
        class(bounded_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        real(wp) :: value
        if (self%outside(q, value)) then
            gradient = value
            return
        end if
        gradient = p
    end subroutine bounded_dp

    subroutine bounded_phi(self, q, phi)
        class(bounded_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        real(wp) :: value
        if (self%outside(q, value)) then
            phi = value
            return
        end if
        phi(1) = q(1)**2 + q(2)**2 - 1
    end subroutine bounded_phi

    subroutine bounded_jac(self, q, jacobian)
        class(bounded_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        real(wp) :: value
        if (self%outside(q, value)) then
            jacobian = value
            return
        end if
        jacobian(1, :) = 2 * q
    end subroutine bounded_jac

    logical function bounded_mass(self, mass) result(declared)
        class(bounded_pendulum), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass = 1
        declared = self%n > 0
    end function bounded_mass

end module test_refusal
