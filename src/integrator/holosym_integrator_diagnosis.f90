!> category: internal submodule (use holosym)
!! Failure diagnosis of `constrained_integrator`: the code of the cause of a failed step
!! (a start state beyond the range of the numbers, h below the resolution of the state,
!! constraints dependent at the start or within the step, h too large for the step's
!! equations) where the solver's own code would mislead, and the resolution limit of a
!! state, which the checks before a step use too.
submodule (holosym_integrator) holosym_failure_diagnosis
    use holosym_status_codes, only: HOLOSYM_NONFINITE_VALUE, HOLOSYM_SINGULAR_MATRIX, &
        HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, HOLOSYM_NEWTON_NOT_CONVERGED, &
        HOLOSYM_NEWTON_DIVERGED, HOLOSYM_STEP_TOO_LARGE, HOLOSYM_STEP_TOO_SMALL
    use holosym_newton, only: newton_report_t, newton_solve, stagnation_floor
    use holosym_reduced_step, only: reduced_report_t
    implicit none

    !> A singular Newton matrix is put down to the constraints when Phi Phi^T has a relative
    !! pivot below this, at the step's start or at a node of the iterate (singular values
    !! of Phi below epsilon**(1/4) relative): there they are nearly dependent, and their
    !! multipliers are determined to no digit in real64 and to few in working precision.
    real(wp), parameter :: dependence_threshold = sqrt(epsilon(1.0_wp))
    !> Factor on the nominal resolution limit of a state (`resolution_limit`): the step's
    !! equations amplify the round-off of q; on the pendulums Newton fails from h = 1e-11
    !! (real128) where the nominal limit is 6e-12, and never from 3e-11 on.
    real(wp), parameter :: resolution_margin = 64
    !> A singular step whose Newton matrix at the constant guess is this many times better
    !! conditioned (pivot ratio) at h/16 than at h is too large: beyond the system's time
    !! scale the ratio falls like 1/h (16 times per factor 16), below it it rises with h.
    real(wp), parameter :: large_step_gain = 4
contains

    !> Say why a step failed, where the solver's code alone would mislead:
    !! HOLOSYM_NONFINITE_VALUE naming the Hamiltonian when H of the start state is not
    !! finite (it overflows);
    !! HOLOSYM_STEP_TOO_SMALL when h is below the resolution of the state
    !! (`resolution_limit`); HOLOSYM_RANK_DEFICIENT_CONSTRAINTS when a singular Newton
    !! matrix comes from constraints dependent at the start or at a node of the iterate;
    !! HOLOSYM_STEP_TOO_LARGE when the equations at the constant guess overflow at h, or
    !! (singular matrix) are far better conditioned at h/16 (`probe_step`). A singular
    !! matrix with none of these causes keeps its code with the hint about N and G.
    module subroutine diagnose_failure(self, sys, q, p, h, status)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(holosym_status_t), intent(inout) :: status
        character(len=:), allocatable :: message
        real(wp) :: limit, ratio, smaller_ratio, probe_h, lower, upper
        integer :: code, k

        select case (status%code)
        case (HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED, &
              HOLOSYM_NONFINITE_VALUE)
        case default
            return
        end select
        if (.not. is_finite(sys%hamiltonian(q, p))) then
            ! A state beyond the range of the system's numbers (e.g. momenta whose energy
            ! overflows): no step size helps.
            status%code = HOLOSYM_NONFINITE_VALUE
            status%message = trim(step_label(self, h)) // ": hamiltonian returned NaN or " // &
                "Inf at the start state (" // status%message // ")"
            return
        end if
        if (status%code == HOLOSYM_NONFINITE_VALUE) return
        limit = resolution_limit(self, sys, q, p)
        if (h < limit) then
            status%code = HOLOSYM_STEP_TOO_SMALL
            status%message = trim(step_label(self, h)) // ": h is below the resolution " // &
                "of this state: under about h = " // real_str(limit) // " the round-off of q " // &
                "(epsilon |q|) divided by h exceeds Newton's stagnation level in the " // &
                "momenta, so the step's equations cannot be solved; use h >= " // &
                real_str(limit) // " (" // status%message // ")"
            return
        end if
        if (status%code == HOLOSYM_SINGULAR_MATRIX) then
            if (.not. rank_test(self, sys, q, message, dependence_threshold)) then
                status%code = HOLOSYM_RANK_DEFICIENT_CONSTRAINTS
                status%message = trim(step_label(self, h)) // ": at the start of the step " // &
                    message
                return
            else if (len(self%dependent_nodes) > 0) then
                status%code = HOLOSYM_RANK_DEFICIENT_CONSTRAINTS
                status%message = trim(step_label(self, h)) // ": within the step (" // &
                    self%dependent_nodes // "); the constraints become dependent"
                return
            end if
        end if
        ! Too large: the step's equations at the constant guess overflow; or, for a
        ! singular matrix, they are far worse conditioned at h (or the largest step below
        ! it where they are regular) than at a sixteenth of it: the pivot ratio at the
        ! constant guess falls like 1/h beyond the system's time scale, and rises with h
        ! below it.
        code = probe_step(self, sys, q, p, h, ratio)
        if (code == HOLOSYM_NEWTON_DIVERGED) then
            status%code = HOLOSYM_STEP_TOO_LARGE
            status%message = trim(step_label(self, h)) // ": the step is too large: its " // &
                "equations overflow working precision at the first guess; reduce h (" // &
                status%message // ")"
            return
        end if
        if (status%code == HOLOSYM_SINGULAR_MATRIX) then
            ! A step size below h with a regular matrix at the guess: bisection in log h
            ! between h and the resolution limit (beyond the system's time scale the
            ! matrix is singular above some step size, regular below it).
            probe_h = h
            lower = max(limit, sqrt(tiny(1.0_wp)))
            upper = h
            do k = 1, 64
                if (ratio > 0 .or. upper <= 16 * lower) exit
                probe_h = sqrt(lower) * sqrt(upper)
                code = probe_step(self, sys, q, p, probe_h, ratio)
                if (ratio <= 0) upper = probe_h
            end do
            if (ratio > 0) then
                code = probe_step(self, sys, q, p, probe_h / 16, smaller_ratio)
                if (code /= HOLOSYM_NEWTON_DIVERGED .and. smaller_ratio > 0 .and. &
                    smaller_ratio >= large_step_gain * ratio) then
                    status%code = HOLOSYM_STEP_TOO_LARGE
                    status%message = trim(step_label(self, h)) // ": the step is too large: " // &
                        "the Newton matrix at the first guess has pivot ratio " // &
                        real_str(ratio) // " at h = " // real_str(probe_h) // " and " // &
                        real_str(smaller_ratio) // " at h/16 (at this h it is singular to " // &
                        "working precision in the solve); reduce h (" // status%message // ")"
                    return
                end if
            end if
        end if
        if (status%code == HOLOSYM_SINGULAR_MATRIX) then
            if (self%scheme%order_m >= self%scheme%order_n + 2) then
                status%message = status%message // "; M >= N + 2 is singular whenever " // &
                    "H is degenerate along the surplus displacement modes (e.g. a " // &
                    "symmetric potential): use N = M - 1"
            else
                status%message = status%message // "; N or G may be too small for M " // &
                    "(N = M - 1 with G >= M works), or the constraints are nearly dependent"
            end if
        end if
    end subroutine diagnose_failure

    !> The smallest step size the state (q, p) resolves: the round-off of q, epsilon |q|,
    !! makes the velocity z/h of a step uncertain by epsilon |q| / h, i.e. the momenta by
    !! that times a mass |p| / |H_p|; Newton accepts corrections at its stagnation level
    !! (relative to the state's size), so below
    !! h = margin epsilon |q| (|p| / |H_p|) / (stagnation_level max(|q|, |p|)) a step may
    !! fail, `resolution_margin` covering the conditioning of the step's equations.
    function resolution_limit(self, sys, q, p) result(limit)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: limit
        call sys%dh_dp(q, p, self%hp_work)
        limit = state_resolution(self, q, p, self%hp_work)
    end function resolution_limit

    !> `resolution_limit` from the velocity field hp = H_p(q, p); 0 when a value is not
    !! finite.
    module pure function state_resolution(self, q, p, hp) result(limit)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:), hp(:)
        real(wp) :: limit
        real(wp) :: scale, mass, velocity, level
        limit = 0
        if (.not. (all(is_finite(q)) .and. all(is_finite(p)) .and. all(is_finite(hp)))) return
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (.not. scale > 0) scale = 1
        velocity = maxval(abs(hp))
        mass = 1
        if (velocity > 0 .and. maxval(abs(p)) > 0) mass = maxval(abs(p)) / velocity
        level = max(stagnation_floor(self%newton), self%newton%tolerance)
        limit = resolution_margin * epsilon(1.0_wp) * maxval(abs(q)) * mass / (level * scale)
    end function state_resolution

    !> One Newton iteration of the step of size h from (q, p) at the constant guess, on the
    !! plain path (working-precision LU; real64 factors where only the reduced step exists):
    !! HOLOSYM_NEWTON_DIVERGED when the equations overflow there, HOLOSYM_SINGULAR_MATRIX
    !! when the Newton matrix is singular there, else HOLOSYM_SUCCESS; `pivot_ratio` the
    !! smallest relative pivot of that matrix (0 when singular). Only the schemes' bound
    !! step and the reduced step's kept factors change.
    integer function probe_step(self, sys, q, p, h, pivot_ratio) result(code)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        real(wp), intent(out) :: pivot_ratio
        type(newton_settings_t) :: settings
        type(newton_report_t) :: report
        type(holosym_status_t) :: local
        type(reduced_report_t) :: reduced_report
        real(wp), allocatable :: x(:)
        real(wp) :: scale
        settings = plain_settings(self%newton)
        settings%max_iterations = 1
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (.not. scale > 0) scale = 1
        if (self%path%general_ready) then
            call apply_options(self, h, local)
            call self%scheme%set_step(sys, q, p, h)
            allocate (x(self%scheme%nx))
            call self%scheme%constant_guess(x)
            ! A workspace of its own: the working-precision LU, no kept factors touched.
            call newton_solve(self%scheme, x, settings, scale, report, local)
            pivot_ratio = report%pivot_ratio
        else
            call self%reduced%solve(sys, q, p, h, settings, stagnation_floor(self%newton), &
                .false., self%q_end_work, self%p_end_work, reduced_report, local)
            pivot_ratio = reduced_report%pivot_ratio
        end if
        select case (local%code)
        case (HOLOSYM_NEWTON_DIVERGED, HOLOSYM_SINGULAR_MATRIX)
            code = local%code
        case default
            code = HOLOSYM_SUCCESS
        end select
        if (code == HOLOSYM_SINGULAR_MATRIX .or. .not. is_finite(pivot_ratio)) pivot_ratio = 0
    end function probe_step

    !> Record, after a singular Newton matrix, whether the constraints are dependent at a
    !! displacement node of the iterate where it happened (`dependent_nodes`).
    module subroutine record_dependent_nodes(self, sys, q, general)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:)
        logical, intent(in) :: general !! the general scheme's iterate (else the reduced's)
        character(len=:), allocatable :: message
        integer :: i
        if (sys%m == 0 .or. len(self%dependent_nodes) > 0) return
        do i = 1, self%scheme%order_m
            if (general) then
                call self%scheme%node(i, self%q_end_work)
            else
                if (.not. self%reduced%newton%have_singular_x) return
                self%q_end_work = q + &
                    self%reduced%newton%singular_x(self%reduced%scheme%layout%z_col(:, i))
            end if
            if (.not. all(is_finite(self%q_end_work))) cycle
            if (.not. rank_test(self, sys, self%q_end_work, message, &
                                 dependence_threshold)) then
                self%dependent_nodes = "at displacement node " // int_str(i) // " of " // &
                    int_str(self%scheme%order_m) // " of the Newton iterate, " // message
                return
            end if
        end do
    end subroutine record_dependent_nodes

end submodule holosym_failure_diagnosis
