!> category: internal submodule (use holosym)
!! Root verification of `constrained_integrator` (`check_roots`): a solved step whose
!! energy change or momentum jump is suspicious is compared with two steps of h/2, and so
!! is the root from the constant first guess; the root within `root_distance` of them is
!! accepted, else the step fails with HOLOSYM_STEP_TOO_LARGE.
submodule (holosym_integrator) holosym_root_verification
    use holosym_status_codes, only: HOLOSYM_STEP_TOO_LARGE
    implicit none

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

    !> A solved step set aside while another root is tried (`verify_root`).
    type :: step_candidate_t
        type(pending_t) :: pending
        real(wp), allocatable :: x(:)      ! the solution (general or reduced unknowns)
        real(wp), allocatable :: dq(:), dp(:)
    end type step_candidate_t
contains

    !> Whether the solved step may be a spurious Newton root: its energy change exceeds
    !! `root_energy_change` or its momentum polynomial jumps by more than
    !! `root_momentum_jump` (`energy_change`, `momentum_jump`; both are recorded).
    module logical function suspicious(self, sys, q, p, h)
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
        jump = path_momentum_jump(self, p, h)
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (scale > 0) jump = jump / scale
        if (.not. is_finite(jump)) jump = 0
    end function momentum_jump

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
    module subroutine verify_root(self, sys, q, p, h, status)
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
        if (refused(self, h, status)) then
            ! The last accepted step stays the last step (its data were not touched).
            self%have_last = had_last
            return
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

    !> Set the solved step of the last attempt aside.
    subroutine take_candidate(self, candidate)
        class(constrained_integrator), intent(in) :: self
        type(step_candidate_t), intent(out) :: candidate
        candidate%pending = self%pending
        call path_solution(self, candidate%x)
        candidate%dq = self%dq_work
        candidate%dp = self%dp_work
    end subroutine take_candidate

    !> Make a candidate the solved step again (to be committed with `rebind`).
    subroutine restore_candidate(self, candidate)
        class(constrained_integrator), intent(inout) :: self
        type(step_candidate_t), intent(in) :: candidate
        self%pending = candidate%pending
        call path_restore_solution(self, candidate%x)
        self%dq_work = candidate%dq
        self%dp_work = candidate%dp
    end subroutine restore_candidate

end submodule holosym_root_verification
