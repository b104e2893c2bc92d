!> category: internal module (use holosym)
!! One step of the reduced scheme (`holosym_reduced_scheme`): its first guess (the
!! previous step's polynomials extrapolated, or the constant guess), its solve by
!! `kept_newton_solve` (simplified Newton on real64 factors of the Newton matrix, dense or
!! banded, kept across iterations and steps while they contract well; a real64 phase
!! before the working-precision residual), retried once with fresh factors from the
!! constant guess, and its results. The last correction is applied without a confirming
!! residual when the contraction rate says the result is within the tolerance: the step
!! results are then updated to first order through the difference matrix of p_b - p_a.
!! With `approximate`, the solve iterates first without the Newton matrix: with the
!! scheme's iteration matrix without curvature, solved through the multipliers
!! (`holosym_reduced_multipliers`), where it contracts well.
module holosym_reduced_step
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, is_system_fault
    use holosym_problem, only: constrained_hamiltonian
    use holosym_reduced_scheme, only: reduced_scheme_t, reduced_equations
    use holosym_newton, only: newton_settings_t
    use holosym_kept_newton, only: kept_newton_t, kept_report_t, kept_newton_solve
    implicit none
    private

    public :: reduced_step_t, reduced_report_t

    !> Work of one step.
    type :: reduced_report_t
        integer :: iterations = 0            !! Newton iterations (residuals solved with)
        integer :: residuals = 0             !! working-precision residuals
        integer :: lowered_residuals = 0     !! real64 residuals (including the Jacobians')
        integer :: factorizations = 0        !! Newton matrices formed and factored
        integer :: approximate = 0           !! iterations without the Newton matrix
        integer :: paired_residuals = 0      !! residuals summed in double-double arithmetic
        real(wp) :: pivot_ratio = 0          !! of the factors in use
    end type reduced_report_t

    !> The reduced step with its Newton iteration (kept factors) and the previous step
    !! (for extrapolation).
    type :: reduced_step_t
        type(reduced_scheme_t) :: scheme
        !> The iteration's kept factors, what it learnt about them, its workspace; its
        !! `have_singular_x`, `singular_x` say where the last solve found the Newton
        !! matrix singular.
        type(kept_newton_t) :: newton
        !> The step size the kept factors were formed for.
        real(wp) :: factors_h = 0
        real(wp), allocatable :: x(:), dpb_change(:)
        !> The last solve started from the extrapolated guess (else from the constant one).
        logical :: extrapolated = .false.
        ! The previous accepted step (see `accept`).
        logical :: have_last = .false.
        real(wp), allocatable :: last_x(:), last_qa(:)
        real(wp) :: last_h = 0
    contains
        procedure :: init => step_init
        procedure :: solve => step_solve
        procedure :: accept => step_accept
        procedure :: forget => step_forget
    end type reduced_step_t

contains

    !> Set up for a system and (M, N, G); codes of `reduced_scheme_t%init`.
    subroutine step_init(self, sys, order_m, order_n, gauss_points, status)
        class(reduced_step_t), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        integer, intent(in) :: order_m, order_n, gauss_points
        type(holosym_status_t), intent(out) :: status
        integer :: nx
        call self%scheme%init(sys, order_m, order_n, gauss_points, status)
        if (.not. status%ok()) return
        nx = self%scheme%nx
        call self%newton%setup(nx, self%scheme%layout%kl, self%scheme%layout%ku)
        if (allocated(self%x)) deallocate (self%x, self%dpb_change, self%last_x, self%last_qa)
        allocate (self%x(nx), self%dpb_change(sys%n), self%last_x(nx), self%last_qa(sys%n))
        call self%forget()
    end subroutine step_init

    !> Forget the kept factors, what earlier steps taught about them and the previous step:
    !! the next steps then depend only on their own inputs.
    subroutine step_forget(self)
        class(reduced_step_t), intent(inout) :: self
        call self%newton%forget()
        self%factors_h = 0
        self%have_last = .false.
    end subroutine step_forget

    !> Solve the step from (q, p) with size h: increments dq = q_b - q_a, dpb = p_b - p_a,
    !! and the solution in `x`; `accept` makes it the previous step of the next solve.
    !! `settings` (the integrator's `newton`): `tolerance` bounds the Newton error relative
    !! to the state's size, `stagnation` is the round-off floor of the corrections, and
    !! `max_iterations`, `max_growth`, `contraction_limit`, `jacobian_cost`,
    !! `pivot_tolerance` act as in `newton_solve`; `continues` starts from the previous
    !! accepted step's polynomials (when its h is the same); `approximate` iterates first
    !! without the Newton matrix where that contracts (default: no); `double_double` sums
    !! the working-precision residuals in double-double arithmetic (default: no). On
    !! failure the kept factors and the previous step are dropped. Codes:
    !! HOLOSYM_SINGULAR_MATRIX,
    !! HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NEWTON_DIVERGED (also equations that overflow),
    !! HOLOSYM_NONFINITE_VALUE (from the system's procedures).
    subroutine step_solve(self, sys, q, p, h, settings, stagnation, continues, dq, dpb, &
                          report, status, approximate, double_double)
        class(reduced_step_t), intent(inout), target :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        type(newton_settings_t), intent(in) :: settings !! Newton's settings
        real(wp), intent(in) :: stagnation  !! round-off floor of the corrections (relative)
        logical, intent(in) :: continues    !! (q, p) is the previous step's end: extrapolate
        real(wp), intent(out) :: dq(:), dpb(:)
        type(reduced_report_t), intent(out) :: report
        type(holosym_status_t), intent(out) :: status
        logical, intent(in), optional :: approximate !! without the Newton matrix first
        logical, intent(in), optional :: double_double !! residual sums in double-double
        type(reduced_equations) :: equations
        type(kept_report_t) :: work
        real(wp) :: scale
        integer :: residuals0, lowered0, paired0

        residuals0 = self%scheme%residuals
        lowered0 = self%scheme%lowered_residuals
        paired0 = self%scheme%paired_residuals
        call self%scheme%set_step(sys, q, p, h, status, double_double)
        if (.not. status%ok()) return
        equations%scheme => self%scheme
        scale = max(maxval(abs(q)), maxval(abs(p)))
        if (scale <= 0) scale = 1
        if (h /= self%factors_h) call self%newton%invalidate()
        self%extrapolated = continues .and. self%have_last .and. h == self%last_h
        if (self%extrapolated) then
            call self%scheme%extrapolated_guess(self%last_x, self%last_qa, q, self%x)
        else
            self%x = 0
        end if
        call kept_newton_solve(equations, self%x, self%newton, settings, scale, stagnation, &
                               work, status, approximate=approximate)
        if (.not. status%ok() .and. .not. is_system_fault(status%code)) then
            ! Kept factors may be stale, or the extrapolation poor: fresh factors from the
            ! constant guess.
            call self%newton%invalidate()
            self%extrapolated = .false.
            self%x = 0
            call kept_newton_solve(equations, self%x, self%newton, settings, scale, &
                                   stagnation, work, status, retry=.true.)
        end if
        report%iterations = work%iterations
        report%factorizations = work%factorizations
        report%approximate = work%approximate
        report%residuals = self%scheme%residuals - residuals0
        report%lowered_residuals = self%scheme%lowered_residuals - lowered0
        report%paired_residuals = self%scheme%paired_residuals - paired0
        report%pivot_ratio = real(self%newton%factors%pivot_ratio, wp)
        if (.not. status%ok()) then
            call self%newton%invalidate()
            self%have_last = .false.
            return
        end if
        self%factors_h = h
        call finish(self, dq, dpb)
    end subroutine step_solve

    !> The step's results, accepted without a confirming residual: from the evaluation at
    !! the last iterate, updated to first order across the last correction (a tolerance
    !! the real64 phase meets needs no working-precision residual at all), through the
    !! matrix that gave it.
    subroutine finish(self, dq, dpb)
        class(reduced_step_t), intent(inout) :: self
        real(wp), intent(out) :: dq(:), dpb(:)
        call self%scheme%increments(dq, dpb, self%newton%ended_lowered)
        if (self%newton%ended_approximate) then
            call self%scheme%multiplier_dp_change(-self%newton%delta, self%dpb_change)
        else
            call self%scheme%linear_dp_change(-self%newton%delta, self%dpb_change)
        end if
        dq = self%x(self%scheme%layout%z_col(:, self%scheme%order_m))
        dpb = dpb + self%dpb_change
    end subroutine finish

    !> Make the last solution (`x`, from q with step h) the previous step of the next solve.
    subroutine step_accept(self, q, h)
        class(reduced_step_t), intent(inout) :: self
        real(wp), intent(in) :: q(:) !! start coordinates of the solved step
        real(wp), intent(in) :: h    !! its step size
        self%last_x = self%x
        self%last_qa = q
        self%last_h = h
        self%have_last = .true.
    end subroutine step_accept

end module holosym_reduced_step
