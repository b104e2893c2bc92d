!> category: internal submodule (use holosym)
!! One step of `constrained_integrator`: its Newton solve, without accepting it, by the
!! reduced step when active (the general scheme its fallback for small systems), else by
!! the general scheme, whose solve is retried with fresh factors, from the constant first
!! guess and on the plain path (full Newton, working-precision LU) before it fails; the
!! checks of the solution's end state and displacement nodes; the check of its root and
!! its diagnosis on failure (`solve_step`); its acceptance (`commit_step`).
submodule (holosym_integrator) holosym_step_solution
    use holosym_status_codes, only: HOLOSYM_NONFINITE_VALUE, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, is_system_fault
    use holosym_problem, only: clear_refusal, refusal_pending, check_refusal
    use holosym_newton, only: newton_report_t, newton_solve, all_finite, stagnation_floor, &
        LINEAR_SOLVER_NATIVE, default_newton_tolerance
    use holosym_projection, only: project_to_manifold, project_sparse
    use holosym_scheme, only: scheme_counters_t
    use holosym_manifold, only: manifold_residuals
    use holosym_reduced_step, only: reduced_report_t
    implicit none

contains

    !> One step from (q, p), which stay unchanged: solve (`attempt_step`), check the root
    !! (`energy_change`, `verify_root`) and accept it (`commit_step`: the increments in
    !! self%dq_work, self%dp_work, the step's data in self%last_*). On failure the code
    !! says why (`diagnose_failure`) and the last accepted step stays the last step.
    module subroutine solve_step(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(out) :: status
        self%dependent_nodes = ""
        call clear_refusal()
        call attempt_step(self, sys, q, p, h, .true., status)
        if (refused(self, h, status)) return
        if (.not. status%ok()) then
            call diagnose_failure(self, sys, q, p, h, status)
            return
        end if
        if (self%check_roots) then
            if (suspicious(self, sys, q, p, h)) then
                call verify_root(self, sys, q, p, h, status)
                return
            end if
            if (refused(self, h, status)) return
            if (.not. self%pending%energy_finite) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, trim(step_label(self, h)) // &
                    ": hamiltonian returned NaN or Inf at the start or the end of the step")
                return
            end if
        end if
        call commit_step(self, sys, q, p, h, .false.)
    end subroutine solve_step

    !> Whether the system refused a point (`refuse`) since the step began: then the step
    !! fails with HOLOSYM_OUTSIDE_DOMAIN and the system's reason, whatever else happened.
    module logical function refused(self, h, status)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: h
        type(holosym_status_t), intent(inout) :: status
        refused = refusal_pending()
        if (refused) call check_refusal(status, trim(step_label(self, h)))
    end function refused

    !> Solve the step from (q, p) without accepting it: the reduced step when active (the
    !! general scheme its fallback for small systems), else the general scheme. With
    !! `extrapolation` false both start from the constant first guess.
    module subroutine attempt_step(self, sys, q, p, h, extrapolation, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: extrapolation
        type(holosym_status_t), intent(out) :: status
        character(len=:), allocatable :: reduced_message
        if (self%path%main == STEP_GENERAL) then
            call solve_general(self, sys, q, p, h, extrapolation, status)
        else
            call solve_reduced(self, sys, q, p, h, extrapolation, status)
            if (.not. (status%ok() .or. .not. self%path%general_ready .or. &
                       .not. self%general_fallback .or. is_system_fault(status%code))) then
                ! The reduced step factors its Newton matrix in real64 only: where that is
                ! too ill-conditioned (nearly dependent constraints), the general step of a
                ! small system has working-precision factors to fall back on (from the
                ! constant guess).
                reduced_message = status%message
                call solve_general(self, sys, q, p, h, .false., status)
                if (.not. status%ok()) &
                    status%message = status%message // " (after the " // reduced_message // ")"
            end if
        end if
        if (status%ok()) call node_residual(self, sys, q, h, status)
        if (status%ok() .and. self%project_end_state .and. &
            self%newton%tolerance > default_newton_tolerance) &
            call project_end(self, sys, q, p, h, status)
    end subroutine attempt_step

    !> `project_end_state`: the solved step's end state (q + dq_work, p + dp_work) onto
    !! the constraints, banded on the reduced path (its system has a constant diagonal
    !! mass), else dense (`project_to_manifold`). The increments take the correction as
    !! the difference of the projected and the unprojected end, exact for such close
    !! numbers; `pending` has max |phi| and max |Phi H_p| at the projected end.
    subroutine project_end(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(inout) :: status
        real(wp) :: position, velocity, scaled_position, scaled_velocity
        if (sys%m == 0) return
        self%q_end_work = q + self%dq_work
        self%p_end_work = p + self%dp_work
        if (self%path%main == STEP_REDUCED) then
            associate (lay => self%reduced%scheme%layout)
                call project_sparse(sys, lay%phi_rows, lay%phi_cols, lay%constraint_order, &
                    self%reduced%scheme%inv_mass, self%q_end_work, self%p_end_work, &
                    position, velocity, status)
            end associate
        else
            call project_to_manifold(sys, self%q_end_work, self%p_end_work, status)
            if (status%ok()) call manifold_residuals(sys, self%q_end_work, self%p_end_work, &
                position, velocity, scaled_position, scaled_velocity)
        end if
        if (.not. status%ok()) then
            status%message = trim(step_label(self, h)) // ": projection of the end state " // &
                "onto the constraints (project_end_state): " // status%message
            return
        end if
        self%dq_work = self%dq_work + (self%q_end_work - (q + self%dq_work))
        self%dp_work = self%dp_work + (self%p_end_work - (p + self%dp_work))
        self%pending%end_position = position
        self%pending%velocity = velocity
    end subroutine project_end

    !> max |phi| over the displacement nodes of the solved step, into `pending`; or
    !! HOLOSYM_NONFINITE_VALUE when `constraint` returns NaN or Inf at one of them (found by
    !! classification: no comparison with a NaN).
    subroutine node_residual(self, sys, q, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), h
        type(holosym_status_t), intent(inout) :: status
        real(wp) :: phi(sys%m)
        integer :: i
        self%pending%position = 0
        self%pending%end_position = 0
        if (sys%m == 0) return
        do i = 0, self%scheme%order_m
            ! The node in p_end_work, free until `energy_change`.
            call path_node(self, q, i, self%p_end_work)
            call sys%constraint(self%p_end_work, phi)
            if (.not. all(is_finite(phi))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, trim(step_label(self, h)) // &
                    ": constraint returned NaN or Inf at displacement node " // int_str(i) // &
                    " of the solved step")
                return
            end if
            self%pending%position = max(self%pending%position, maxval(abs(phi)))
        end do
        self%pending%end_position = maxval(abs(phi))
    end subroutine node_residual

    !> Accept the step solved by the last attempt (or restored by `restore_candidate`):
    !! it becomes the last step (dense output, extrapolation, `last_step`). `rebind` binds
    !! the general scheme to this step again (after other attempts).
    module subroutine commit_step(self, sys, q, p, h, rebind)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: rebind
        call path_accept(self, sys, q, p, h, rebind)
        associate (info => self%last_info, pending => self%pending)
            info%newton_iterations = pending%iterations
            info%constraint_residual = pending%position
            info%end_constraint_residual = pending%end_position
            info%velocity_residual = pending%velocity
            info%pivot_ratio = pending%pivot_ratio
            info%lu_factorizations = pending%factorizations
            info%residual_evaluations = pending%residuals
            info%lowered_residual_evaluations = pending%lowered
            info%gradient_evaluations = pending%gradients
            info%hessian_evaluations = pending%hessians
        end associate
        self%last_qa = q
        self%last_pa = p
        self%last_h = h
        self%last_qb = q + self%dq_work
        self%last_pb = p + self%dp_work
        self%last_energy = self%pending%energy
        self%last_energy_known = self%pending%energy_known
        self%have_last = .true.
        self%stats%steps = self%stats%steps + 1
    end subroutine commit_step

    !> Solve the step by the general scheme (all unknowns, dense Newton), without accepting
    !! it: the solution in x_work, the increments in dq_work, dp_work, its numbers in
    !! `pending`. `extrapolation` allows the previous step's polynomials as first guess.
    subroutine solve_general(self, sys, q, p, h, extrapolation, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: extrapolation
        type(holosym_status_t), intent(out) :: status
        real(wp) :: scale, end_velocity_residual
        type(newton_report_t) :: report
        type(scheme_counters_t) :: counters0
        logical :: extrapolated, from_extrapolation
        integer :: iterations, factorizations

        status%code = HOLOSYM_SUCCESS
        counters0 = self%scheme%counters
        call self%scheme%set_step(sys, q, p, h)
        extrapolated = .false.
        if (self%extrapolate .and. extrapolation) extrapolated = &
            continues_last_step(self, q, p) .and. self%path%last == STEP_GENERAL
        call first_guess()
        ! Increments are compared with the size of the state, not with themselves.
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (scale <= 0) scale = 1
        iterations = 0
        factorizations = 0
        end_velocity_residual = 0
        call solve_with_retries(self%newton)
        if (.not. status%ok() .and. .not. is_system_fault(status%code) .and. &
            fast_options(self)) then
            ! The speed options are heuristics: before failing the step, the plain path
            ! (full Newton, working-precision LU, no pre-solve) gets its chance.
            call self%workspace%invalidate()
            self%workspace%linear_solver = LINEAR_SOLVER_NATIVE
            call first_guess()
            call solve_with_retries(plain_settings(self%newton))
            call self%workspace%invalidate()
            ! The next steps use the chosen linear solver again.
            self%workspace%linear_solver = self%applied_modes(1)
        end if
        call count_general_work(self, counters0, iterations, factorizations, status%ok())
        if (.not. status%ok()) then
            status%message = trim(step_label(self, h)) // ": " // status%message
            return
        end if
        self%pending%step = STEP_GENERAL
        self%pending%extrapolated = from_extrapolation
        self%pending%pivot_ratio = report%pivot_ratio
        ! Hidden constraint at the step end, max |Phi(q_b) H_p(q_b, p_b)|
        ! (check_general_end_state).
        self%pending%velocity = end_velocity_residual

    contains

        !> Newton from x_work with `settings`; on failure retry with fresh factors (kept
        !! ones may be stale) and from the constant guess (a poor extrapolation should
        !! not fail the step). On success the step's increments are in dq_work, dp_work
        !! and the end state is checked against the constraints.
        subroutine solve_with_retries(settings)
            type(newton_settings_t), intent(in) :: settings
            call attempt(settings)
            if (.not. status%ok() .and. report%reused_factors .and. &
                .not. is_system_fault(status%code)) call attempt(settings)
            if (.not. status%ok() .and. extrapolated .and. &
                .not. is_system_fault(status%code)) then
                call self%scheme%constant_guess(self%x_work)
                from_extrapolation = .false.
                call attempt(settings)
            end if
            if (.not. status%ok()) return
            call self%scheme%increments(self%x_work, self%dq_work, self%dp_work, status)
            if (.not. status%ok()) return
            if (.not. (all_finite(self%dq_work) .and. all_finite(self%dp_work))) then
                call set_status(status, HOLOSYM_NEWTON_DIVERGED, "step produced a " // &
                    "non-finite state (overflow)")
                return
            end if
            call check_general_end_state(self, sys, q, p, end_velocity_residual, status)
        end subroutine solve_with_retries

        !> x_work = the previous step's polynomials extrapolated, or the constant guess.
        subroutine first_guess()
            from_extrapolation = extrapolated
            if (extrapolated) then
                call self%scheme%extrapolated_guess(self%last_x, self%last_qa, self%last_pa, &
                                                    self%last_h, q, p, h, self%x_work)
            else
                call self%scheme%constant_guess(self%x_work)
            end if
        end subroutine first_guess

        !> One Newton solve from x_work, its work added to the step's.
        subroutine attempt(settings)
            type(newton_settings_t), intent(in) :: settings
            call newton_solve(self%scheme, self%x_work, settings, scale, report, status, &
                              self%workspace)
            iterations = iterations + report%iterations
            factorizations = factorizations + report%factorizations
            if (status%code == HOLOSYM_SINGULAR_MATRIX) &
                call record_dependent_nodes(self, sys, q, .true.)
        end subroutine attempt

    end subroutine solve_general

    !> A Newton iteration that stopped far from a solution (e.g. at an absurd h, where the
    !! relative test is met by huge iterates) leaves the end state off the constraint
    !! manifold: fail the general scheme's solve when a scaled residual of the end state
    !! (q + dq_work, p + dp_work) exceeds `end_state_tolerance` (loose: nearly dependent
    !! constraints legitimately end steps some orders above epsilon). H_p at the end state
    !! is left in hp_work.
    subroutine check_general_end_state(self, sys, q, p, end_velocity, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:), p(:) !! start state of the step
        real(wp), intent(out) :: end_velocity !! max |Phi H_p| at the end state
        type(holosym_status_t), intent(inout) :: status !! outcome of the solve
        real(wp) :: position, velocity, scaled_position, scaled_velocity
        self%q_end_work = q + self%dq_work
        self%p_end_work = p + self%dp_work
        call manifold_residuals(sys, self%q_end_work, self%p_end_work, position, &
                                velocity, scaled_position, scaled_velocity, self%hp_work)
        self%scheme%counters%gradients = self%scheme%counters%gradients + 1
        end_velocity = velocity
        call end_state_status(position, velocity, scaled_position, scaled_velocity, &
                              end_tolerance(self), status)
    end subroutine check_general_end_state

    !> The work of the general scheme's solve (`record_work`): Newton iterations and
    !! factorisations as counted by the solve, evaluations as the scheme's counters grew
    !! since `start`.
    subroutine count_general_work(self, start, iterations, factorizations, solved)
        class(constrained_integrator), intent(inout) :: self
        type(scheme_counters_t), intent(in) :: start !! the scheme's counters before the solve
        integer, intent(in) :: iterations     !! Newton iterations of the solve
        integer, intent(in) :: factorizations !! LU factorisations of the solve
        logical, intent(in) :: solved         !! the solve succeeded
        associate (now => self%scheme%counters)
            call record_work(self, iterations, factorizations, &
                int(now%residuals - start%residuals), &
                int(now%lowered_residuals - start%lowered_residuals), &
                int(now%gradients - start%gradients), int(now%hessians - start%hessians), &
                solved)
        end associate
    end subroutine count_general_work

    !> The work of a solve by either step: added to `stats`, and when it `solved` the
    !! step, the pending step's numbers.
    subroutine record_work(self, iterations, factorizations, residuals, lowered, gradients, &
                           hessians, solved)
        class(constrained_integrator), intent(inout) :: self
        integer, intent(in) :: iterations, factorizations !! Newton iterations, LU
        integer, intent(in) :: residuals, lowered !! working-precision and real64 residuals
        integer, intent(in) :: gradients, hessians !! calls of the system's derivatives
        logical, intent(in) :: solved !! the solve succeeded
        associate (stats => self%stats)
            stats%newton_iterations = stats%newton_iterations + iterations
            stats%lu_factorizations = stats%lu_factorizations + factorizations
            stats%jacobian_evaluations = stats%jacobian_evaluations + factorizations
            stats%residual_evaluations = stats%residual_evaluations + residuals
            stats%lowered_residual_evaluations = stats%lowered_residual_evaluations + lowered
            stats%gradient_evaluations = stats%gradient_evaluations + gradients
            stats%hessian_evaluations = stats%hessian_evaluations + hessians
        end associate
        if (.not. solved) return
        self%pending%iterations = iterations
        self%pending%factorizations = factorizations
        self%pending%residuals = residuals
        self%pending%lowered = lowered
        self%pending%gradients = gradients
        self%pending%hessians = hessians
    end subroutine record_work

    !> The end-state test of a solved step: non-finite residuals (from the system's
    !! constraint or dh_dp at the end state) fail with HOLOSYM_NONFINITE_VALUE, scaled
    !! residuals above `end_state_tolerance` with HOLOSYM_NEWTON_NOT_CONVERGED.
    subroutine end_state_status(position, velocity, scaled_position, scaled_velocity, &
                                tolerance, status)
        real(wp), intent(in) :: position, velocity, scaled_position, scaled_velocity
        real(wp), intent(in) :: tolerance !! largest accepted scaled residual
        type(holosym_status_t), intent(inout) :: status
        if (.not. (is_finite(scaled_position) .and. is_finite(scaled_velocity))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "constraint, " // &
                "constraint_jacobian or dh_dp returned NaN or Inf at the end state")
        else if (scaled_position > tolerance .or. scaled_velocity > tolerance) then
            call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "Newton stopped at a " // &
                "point off the constraints (end state max|phi| = " // real_str(position) // &
                ", max|Phi H_p| = " // real_str(velocity) // ")")
        end if
    end subroutine end_state_status

    !> Solve the step by the reduced step (momenta eliminated; `holosym_reduced_step`),
    !! without accepting it: the solution in reduced%x, the increments in dq_work, dp_work,
    !! its numbers in `pending`.
    subroutine solve_reduced(self, sys, q, p, h, extrapolation, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: extrapolation
        type(holosym_status_t), intent(out) :: status
        type(reduced_report_t) :: report
        real(wp) :: position, velocity, scaled_position, scaled_velocity
        integer :: gradients0

        gradients0 = self%reduced%scheme%gradients
        call self%reduced%solve(sys, q, p, h, self%newton, stagnation_floor(self%newton), &
            self%extrapolate .and. extrapolation .and. continues_last_step(self, q, p), &
            self%dq_work, self%dp_work, report, status, &
            approximate=self%iteration == "automatic", &
            double_double=paired_sums(self))
        self%stats%approximate_iterations = self%stats%approximate_iterations + &
            report%approximate
        self%stats%paired_residual_evaluations = self%stats%paired_residual_evaluations + &
            report%paired_residuals
        if (status%ok()) then
            if (.not. (all_finite(self%dq_work) .and. all_finite(self%dp_work))) &
                call set_status(status, HOLOSYM_NEWTON_DIVERGED, "step produced a " // &
                "non-finite state (overflow)")
        end if
        if (status%ok()) then
            self%q_end_work = q + self%dq_work
            self%p_end_work = p + self%dp_work
            call state_residuals(self, sys, self%q_end_work, self%p_end_work, position, &
                                 velocity, scaled_position, scaled_velocity, self%hp_work)
            if (sys%m == 0) self%stats%gradient_evaluations = &
                self%stats%gradient_evaluations + 1
            call end_state_status(position, velocity, scaled_position, scaled_velocity, &
                                  end_tolerance(self), status)
        end if
        ! The reduced step keeps no count of its calls of the Hessians (0 here).
        call record_work(self, report%iterations, report%factorizations, report%residuals, &
                         report%lowered_residuals, self%reduced%scheme%gradients - gradients0, &
                         0, status%ok())
        if (.not. status%ok()) then
            if (status%code == HOLOSYM_SINGULAR_MATRIX) &
                call record_dependent_nodes(self, sys, q, .false.)
            status%message = "reduced " // trim(step_label(self, h)) // ": " // status%message
            self%have_last = .false.
            return
        end if
        self%pending%step = STEP_REDUCED
        self%pending%extrapolated = self%reduced%extrapolated
        self%pending%pivot_ratio = report%pivot_ratio
        self%pending%velocity = velocity
    end subroutine solve_reduced

    !> "step with (M, N, G) = (2, 1, 3), h = 1.25000E-0001", for messages, blank-padded:
    !! call sites trim it (a fixed length, not a deferred one: see `int_str`).
    module function step_label(self, h) result(text)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: h
        character(len=80) :: text
        text = "step with (M, N, G) = (" // int_str(self%scheme%order_m) // ", " // &
            int_str(self%scheme%order_n) // ", " // int_str(self%scheme%gauss_points) // &
            "), h = " // real_str(h)
    end function step_label

end submodule holosym_step_solution
