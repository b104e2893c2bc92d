!> A NaN from any of a system's procedures at any call of a short run is
!! HOLOSYM_NONFINITE_VALUE, with the state kept at the last good step, and never a trap: the
!! spherical pendulum with one of its procedures returning NaN at its k-th call, for every
!! procedure and (a spread of) every k of a clean run, on both paths, with the halting on
!! 'invalid' on.
module test_nan_sweep
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_set_halting_mode, &
        ieee_invalid, ieee_support_halting
    use holosym, only: wp, holosym_status_t, constrained_integrator, spherical_pendulum, &
        HOLOSYM_NONFINITE_VALUE
    use holosym_status_codes, only: int_str, status_code_name
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, skip
    implicit none
    private
    public :: nan_sweep_tests

    !> The procedures poisoned, in this order.
    character(len=*), parameter :: procedure_names(8) = [character(len=19) :: &
        "hamiltonian", "dh_dq", "dh_dp", "constraint", "constraint_jacobian", "hessian", &
        "constraint_hessian", "dh_dq_double"]
    integer, parameter :: p_hamiltonian = 1, p_dh_dq = 2, p_dh_dp = 3, p_constraint = 4, &
        p_jacobian = 5, p_hessian = 6, p_constraint_hessian = 7, p_double = 8
    !> At most this many poisoned calls per procedure and path (spread over the run).
    integer, parameter :: calls_tried = 40

    !> Calls of each procedure since `reset`, and the one call that returns NaN.
    type :: poison_t
        integer :: calls(size(procedure_names)) = 0
        integer :: target_procedure = 0
        integer :: target_call = 0
    end type poison_t

    !> The spherical pendulum whose procedure `target_procedure` returns NaN at its call
    !! number `target_call`.
    type, extends(spherical_pendulum) :: poisoned_pendulum
        type(poison_t), pointer :: poison => null()
    contains
        procedure :: hamiltonian => poisoned_hamiltonian
        procedure :: dh_dq => poisoned_dh_dq
        procedure :: dh_dp => poisoned_dh_dp
        procedure :: constraint => poisoned_constraint
        procedure :: constraint_jacobian => poisoned_jacobian
        procedure :: hessian => poisoned_hessian
        procedure :: constraint_hessian => poisoned_constraint_hessian
        procedure :: dh_dq_double => poisoned_double
    end type poisoned_pendulum

contains

    !> The tests of this suite.
    function nan_sweep_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [new_test("nan_at_any_call_is_code_4", nan_at_any_call)]
    end function nan_sweep_tests

    !> Count a call of procedure `which`; whether it is the poisoned one.
    logical function hit(poison, which)
        type(poison_t), intent(inout) :: poison
        integer, intent(in) :: which
        poison%calls(which) = poison%calls(which) + 1
        hit = which == poison%target_procedure .and. &
            poison%calls(which) == poison%target_call
    end function hit

    real(wp) function nan()
        nan = ieee_value(1.0_wp, ieee_quiet_nan)
    end function nan

    function poisoned_hamiltonian(self, q, p) result(energy)
        class(poisoned_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = self%spherical_pendulum%hamiltonian(q, p)
        if (hit(self%poison, p_hamiltonian)) energy = nan()
    end function poisoned_hamiltonian

    subroutine poisoned_dh_dq(self, q, p, gradient)
        class(poisoned_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        call self%spherical_pendulum%dh_dq(q, p, gradient)
        if (hit(self%poison, p_dh_dq)) gradient(1) = nan()
    end subroutine poisoned_dh_dq

    subroutine poisoned_dh_dp(self, q, p, gradient)
        class(poisoned_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        call self%spherical_pendulum%dh_dp(q, p, gradient)
        if (hit(self%poison, p_dh_dp)) gradient(2) = nan()
    end subroutine poisoned_dh_dp

    subroutine poisoned_constraint(self, q, phi)
        class(poisoned_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        call self%spherical_pendulum%constraint(q, phi)
        if (hit(self%poison, p_constraint)) phi(1) = nan()
    end subroutine poisoned_constraint

    subroutine poisoned_jacobian(self, q, jacobian)
        class(poisoned_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        call self%spherical_pendulum%constraint_jacobian(q, jacobian)
        if (hit(self%poison, p_jacobian)) jacobian(1, 3) = nan()
    end subroutine poisoned_jacobian

    subroutine poisoned_hessian(self, q, p, hqq, hqp, hpp)
        class(poisoned_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        call self%spherical_pendulum%hessian(q, p, hqq, hqp, hpp)
        if (hit(self%poison, p_hessian)) then
            hqq(1, 1) = nan()
            hpp(1, 1) = nan()
        end if
    end subroutine poisoned_hessian

    subroutine poisoned_constraint_hessian(self, q, hessian)
        class(poisoned_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        call self%spherical_pendulum%constraint_hessian(q, hessian)
        if (hit(self%poison, p_constraint_hessian)) hessian(1, 1, 1) = nan()
    end subroutine poisoned_constraint_hessian

    subroutine poisoned_double(self, q, p, gradient)
        use holosym_kinds, only: dp
        class(poisoned_pendulum), intent(in) :: self
        real(dp), intent(in) :: q(:), p(:)
        real(dp), intent(out) :: gradient(:)
        call self%spherical_pendulum%dh_dq_double(q, p, gradient)
        if (hit(self%poison, p_double)) gradient(3) = ieee_value(1.0_dp, ieee_quiet_nan)
    end subroutine poisoned_double

    !> For each path and procedure: a clean run of 3 steps counts the calls; then the run
    !! again with the k-th call NaN must fail with HOLOSYM_NONFINITE_VALUE (no other code,
    !! no success, no trap), q and p the state of the last good step.
    subroutine nan_at_any_call(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(poisoned_pendulum) :: sys
        type(poison_t), target :: poison
        real(wp) :: q0(3), p0(3)
        integer :: path, which, k, stride
        integer :: clean(size(procedure_names))
        logical :: halting
        if (.not. ieee_support_halting(ieee_invalid)) then
            call skip(error, "no halting on IEEE exceptions on this processor")
            return
        end if
        sys%spherical_pendulum = spherical_pendulum()
        sys%poison => poison
        call sys%initial_state(q0, p0)
        call ieee_get_halting_mode(ieee_invalid, halting)
        call ieee_set_halting_mode(ieee_invalid, .true.)
        do path = 1, 2
            poison%target_procedure = 0
            call run(path == 1, clean)
            if (allocated(error)) exit
            do which = 1, size(procedure_names)
                stride = max(1, clean(which) / calls_tried)
                do k = 1, clean(which), stride
                    poison%target_procedure = which
                    poison%target_call = k
                    call run(path == 1)
                    if (allocated(error)) exit
                end do
                if (allocated(error)) exit
            end do
            if (allocated(error)) exit
        end do
        call ieee_set_halting_mode(ieee_invalid, halting)
    contains
        !> A fresh integrator, 3 steps from the start (calls counted after init); without
        !! `counted`, the NaN run's outcome checked.
        subroutine run(structured, counted)
            logical, intent(in) :: structured
            integer, intent(out), optional :: counted(:)
            type(constrained_integrator) :: integ
            type(holosym_status_t) :: status
            real(wp) :: q(3), p(3), qs(3), ps(3)
            integer :: steps_done
            character(len=:), allocatable :: label
            integ%structured = structured
            call integ%init(sys, 2, 1, 3, status)
            call check(error, status%ok(), "init: " // status%message)
            if (allocated(error)) return
            poison%calls = 0
            q = q0
            p = p0
            call integ%integrate(sys, q, p, 0.125_wp, 3, steps_done=steps_done, status=status)
            if (present(counted)) then
                counted = poison%calls
                call check(error, status%ok(), "the clean run: " // status%message)
                return
            end if
            label = trim(merge("reduced", "general", structured)) // " path, " // &
                trim(procedure_names(poison%target_procedure)) // " NaN at call " // &
                int_str(poison%target_call)
            call check(error, status%code == HOLOSYM_NONFINITE_VALUE, label // ": " // &
                status_code_name(status%code) // " (" // int_str(status%code) // "): " // &
                status%message)
            if (allocated(error)) return
            call check(error, steps_done >= 0 .and. steps_done < 3, label // &
                ": steps_done " // int_str(steps_done))
            if (allocated(error)) return
            ! The state of the last good step: a clean run of steps_done steps.
            call clean_state(structured, steps_done, qs, ps)
            call check(error, all(q == qs) .and. all(p == ps), label // &
                ": q, p not the last good step's")
        end subroutine run

        !> The clean run's state after `steps` steps.
        subroutine clean_state(structured, steps, qs, ps)
            logical, intent(in) :: structured
            integer, intent(in) :: steps
            real(wp), intent(out) :: qs(:), ps(:)
            type(constrained_integrator) :: integ
            type(poison_t) :: saved
            saved = poison
            poison%target_procedure = 0
            integ%structured = structured
            call integ%init(sys, 2, 1, 3)
            qs = q0
            ps = p0
            call integ%integrate(sys, qs, ps, 0.125_wp, steps)
            poison = saved
        end subroutine clean_state
    end subroutine nan_at_any_call

end module test_nan_sweep
