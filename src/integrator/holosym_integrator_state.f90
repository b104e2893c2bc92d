!> category: internal submodule (use holosym)
!! The checks of `constrained_integrator` on a state: everything a step needs before it
!! touches the state (`validate`: the settings, the sizes, h, the system's consistency,
!! the rank of the constraints, the residuals of the start state), whether a state
!! continues the last step, and the residual and rank tests through Phi's sparse pattern
!! on the reduced path.
submodule (holosym_integrator) holosym_state_checks
    use holosym_status_codes, only: HOLOSYM_INVALID_DIMENSION, HOLOSYM_INVALID_STEP_SIZE, &
        HOLOSYM_OFF_MANIFOLD, HOLOSYM_NONFINITE_VALUE, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
        HOLOSYM_STEP_TOO_SMALL
    use holosym_manifold, only: manifold_residuals, full_rank_constraints, &
        sparse_manifold_residuals, sparse_full_rank_constraints
    use holosym_system_check, only: check_system, system_check_report_t
    use holosym_problem, only: clear_refusal, refusal_pending, check_refusal
    implicit none

    !> What the off-manifold messages advise.
    character(len=*), parameter :: onto_manifold = "put it on the manifold with " // &
        "project_to_manifold (from q and p) or state_from_velocities (from q and dq/dt)"
contains

    !> Check everything a step needs before touching the state (`check_start`); a point
    !! the system refused (`refuse`) during the checks fails them with
    !! HOLOSYM_OUTSIDE_DOMAIN.
    module subroutine validate(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(out) :: status
        call clear_refusal()
        call check_start(self, sys, q, p, h, status)
        call check_refusal(status, "at the start state")
    end subroutine validate

    !> The checks of `validate`, in order: the set-up, the arguments, the start state.
    subroutine check_start(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(out) :: status
        real(wp) :: position, velocity, scaled_position, scaled_velocity, tolerance, hp(size(q))
        character(len=:), allocatable :: rank_message
        logical :: continuing, finite

        if (.not. self%ready) then
            call set_status(status, HOLOSYM_NOT_INITIALIZED, "call init before step or integrate")
        else if (.not. settings_valid(self, rank_message)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, rank_message)
        else if (self%structured .neqv. self%structured_at_init) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "structured was changed " // &
                "after init, which reads it (it chooses the path); call init again")
        else if (sys%n /= self%scheme%n .or. sys%m /= self%scheme%m) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "system has n = " // int_str(sys%n) &
                // ", m = " // int_str(sys%m) // " but the integrator was set up for n = " // &
                int_str(self%scheme%n) // ", m = " // int_str(self%scheme%m))
        else if (size(q) /= sys%n .or. size(p) /= sys%n) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q and p must have size n = " // &
                int_str(sys%n) // "; got " // int_str(size(q)) // " and " // int_str(size(p)))
        else if (.not. is_finite(h)) then
            call set_status(status, HOLOSYM_INVALID_STEP_SIZE, "step size must be positive and " &
                // "finite; got h = " // real_str(h))
        else if (h <= 0) then
            call set_status(status, HOLOSYM_INVALID_STEP_SIZE, "step size must be positive and " &
                // "finite; got h = " // real_str(h))
        else if (h < tiny(h)) then
            ! 1/h would overflow: far below the resolution of any state.
            call set_status(status, HOLOSYM_STEP_TOO_SMALL, "step size h = " // real_str(h) // &
                " is below the smallest normal number " // real_str(tiny(h)) // &
                " and below the resolution of any state")
        else if (.not. (all(is_finite(q)) .and. all(is_finite(p)))) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "q or p contains NaN or Inf")
        else
            ! The end state of this integrator's last step passed its end-state check: as
            ! the next start it needs no rank test (step-by-step callers do not pay one per
            ! step) and meets the end-state tolerance (looser than `manifold_tolerance` when
            ! the Newton tolerance is).
            continuing = continues_last_step(self, q, p)
            tolerance = self%manifold_tolerance
            if (continuing) tolerance = max(tolerance, end_tolerance(self))
            if (.not. continuing) then
                ! An energy beyond the range of the numbers (e.g. |p| = 1e4000) first: every
                ! later test would only see its effects.
                if (.not. is_finite(sys%hamiltonian(q, p))) then
                    call set_status(status, HOLOSYM_NONFINITE_VALUE, "hamiltonian returned " &
                        // "NaN or Inf at the start state")
                    return
                end if
                if (refusal_pending()) return
                ! The system's own consistency next: a wrong declaration (a sparsity
                ! pattern, a Jacobian) would make every later test report its effect.
                call check_once(self, sys, q, p, status)
                if (.not. status%ok()) return
                if (.not. rank_test(self, sys, q, rank_message, finite=finite)) then
                    call set_status(status, HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, rank_message)
                    return
                else if (.not. finite) then
                    call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint_jacobian " // &
                        "returned NaN or Inf at the start state")
                    return
                end if
            end if
            call state_residuals(self, sys, q, p, position, velocity, scaled_position, &
                                 scaled_velocity, hp)
            if (.not. (is_finite(scaled_position) .and. is_finite(scaled_velocity))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, &
                    "constraint, constraint_jacobian " &
                    // "or dh_dp returned NaN or Inf at the start state")
            else if (scaled_position > tolerance) then
                call set_status(status, HOLOSYM_OFF_MANIFOLD, "start state violates the " // &
                    "constraints: max|phi| = " // real_str(position) // " (scaled " // &
                    real_str(scaled_position) // " > tolerance " // &
                    real_str(tolerance) // "); " // onto_manifold)
            else if (scaled_velocity > tolerance) then
                call set_status(status, HOLOSYM_OFF_MANIFOLD, &
                    "start state violates the hidden " // &
                    "constraint: max|Phi H_p| = " // real_str(velocity) // " (scaled " // &
                    real_str(scaled_velocity) // " > tolerance " // &
                    real_str(tolerance) // "); " // onto_manifold)
            else if (h < epsilon(h) * state_resolution(self, q, p, hp)) then
                ! Far below the resolution: the step would move nothing, and its equations
                ! would overflow (1/h) in the real64 parts of the solve.
                call set_status(status, HOLOSYM_STEP_TOO_SMALL, "step size h = " // &
                    real_str(h) // " is far below the resolution of this state (about h = " &
                    // real_str(state_resolution(self, q, p, hp)) // "); use h >= that")
            else
                call set_status(status, HOLOSYM_SUCCESS, "")
            end if
        end if
    end subroutine check_start

    !> The check of the system (`check_system` setting) at the first start state after
    !! `init`: its failure is the call's.
    subroutine check_once(self, sys, q, p, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        type(holosym_status_t), intent(out) :: status
        type(system_check_report_t) :: report
        call set_status(status, HOLOSYM_SUCCESS, "")
        if (.not. self%check_system .or. self%system_checked) return
        call check_system(sys, q, p, report, status)
        if (status%ok()) self%system_checked = .true.
    end subroutine check_once

    !> True when (q, p) is exactly the end state of the last successful step.
    module pure logical function continues_last_step(self, q, p)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        continues_last_step = .false.
        if (self%have_last) continues_last_step = all(q == self%last_qb) .and. &
            all(p == self%last_pb)
    end function continues_last_step

    !> `manifold_residuals`, through Phi's sparse pattern on the reduced path.
    module subroutine state_residuals(self, sys, q, p, position, velocity, scaled_position, &
                               scaled_velocity, velocity_field)
        class(constrained_integrator), intent(in) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: position, velocity, scaled_position, scaled_velocity
        real(wp), intent(out), optional :: velocity_field(:) !! H_p(q, p)
        if (self%path%main == STEP_REDUCED) then
            call sparse_manifold_residuals(sys, self%reduced%scheme%layout%phi_rows, &
                self%reduced%scheme%layout%phi_cols, q, p, position, velocity, &
                scaled_position, scaled_velocity, velocity_field)
        else
            call manifold_residuals(sys, q, p, position, velocity, scaled_position, &
                                    scaled_velocity, velocity_field)
        end if
    end subroutine state_residuals

    !> `full_rank_constraints`, banded through Phi's sparse pattern on the reduced path.
    module logical function rank_test(self, sys, q, message, threshold, finite)
        class(constrained_integrator), intent(in) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:)
        character(len=:), allocatable, intent(out) :: message
        real(wp), intent(in), optional :: threshold !! relative pivot of Phi Phi^T
        logical, intent(out), optional :: finite    !! false: Phi not finite (result true)
        if (self%path%main == STEP_REDUCED) then
            associate (lay => self%reduced%scheme%layout)
                rank_test = sparse_full_rank_constraints(sys, lay%phi_rows, lay%phi_cols, &
                                                         lay%constraint_order, q, message, &
                                                         threshold, finite)
            end associate
        else
            rank_test = full_rank_constraints(sys, q, message, threshold, finite)
        end if
    end function rank_test

end submodule holosym_state_checks
