!> category: internal module (use holosym)
!! The interface every scheme implements: the discrete equations of one step as Newton
!! sees them (`nonlinear_system`: residual, Newton matrix, real64 residual, the Newton
!! matrix factored in the scheme's own pattern) and what the integrator needs of a solved
!! step (its increments, displacement nodes, multipliers, momentum polynomial's ends,
!! dense output) and of the work done (`work`). The general scheme (`discrete_scheme`)
!! extends it; the reduced scheme presents itself through `reduced_equations`. Either
!! Newton iteration (`newton_solve`, `kept_newton_solve`) solves either scheme, and the
!! results of a step read the same through this interface (test
!! `reduced/one_interface_for_both_schemes`).
module holosym_step_scheme
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t
    use holosym_problem, only: constrained_hamiltonian
    use holosym_newton, only: nonlinear_system
    implicit none
    private

    !> Counts of the user-function calls made by a scheme (cumulative since `init`).
    type, public :: scheme_counters_t
        !> Residual evaluations (including those of residual-difference Jacobians).
        integer(int64) :: residuals = 0
        !> Residual evaluations in real64 arithmetic (`residual_lowered`).
        integer(int64) :: lowered_residuals = 0
        !> Jacobian evaluations.
        integer(int64) :: jacobians = 0
        !> Calls of dh_dq or dh_dp (each counts one; difference Hessians add 6n per call).
        integer(int64) :: gradients = 0
        !> Calls of hessian or constraint_hessian (user's or differences).
        integer(int64) :: hessians = 0
    end type scheme_counters_t

    !> The equations of one step of a scheme and what a solved step gives.
    type, abstract, extends(nonlinear_system), public :: step_scheme
    contains
        !> The number of unknowns (and equations) of one step.
        procedure(unknowns_interface), deferred :: unknowns
        !> Bind the system, the start state (qa, pa) and h for the next solve.
        procedure(bind_interface), deferred :: bind
        !> The constant first guess (the start state held over the step, no forces).
        procedure(guess_interface), deferred :: constant_guess
        !> The step's results q_b - q_a, p_b - p_a from a solution x.
        procedure(increments_interface), deferred :: increments
        !> Displacement node q_i (i = 0..M) of a solution.
        procedure(node_interface), deferred :: solution_node
        !> The multipliers lambda_k at the displacement nodes, m x (0:M).
        procedure(multipliers_interface), deferred :: node_values
        !> Distance of the momentum polynomial's ends from p_a and p_b = p_a + dp.
        procedure(jump_interface), deferred :: momentum_jump
        !> q~, p~, lambda~ at tau in [0, 1] of a solved step (x from qa, pa with step h).
        procedure(dense_interface), deferred :: dense
        !> The user-function calls made so far.
        procedure(work_interface), deferred :: work
    end type step_scheme

    abstract interface
        pure integer function unknowns_interface(self)
            import :: step_scheme
            class(step_scheme), intent(in) :: self
        end function unknowns_interface

        subroutine bind_interface(self, sys, qa, pa, h, status)
            import :: step_scheme, constrained_hamiltonian, wp, holosym_status_t
            class(step_scheme), intent(inout) :: self
            class(constrained_hamiltonian), intent(in), target :: sys !! the system
            real(wp), intent(in) :: qa(:), pa(:) !! start state
            real(wp), intent(in) :: h            !! step size
            type(holosym_status_t), intent(out) :: status !! a refusal or non-finite value
        end subroutine bind_interface

        subroutine guess_interface(self, x)
            import :: step_scheme, wp
            class(step_scheme), intent(in) :: self
            real(wp), intent(out) :: x(:) !! unknowns
        end subroutine guess_interface

        subroutine increments_interface(self, x, dq, dp, status)
            import :: step_scheme, wp, holosym_status_t
            class(step_scheme), intent(inout) :: self
            real(wp), intent(in) :: x(:)    !! solution
            real(wp), intent(out) :: dq(:)  !! q_b - q_a
            real(wp), intent(out) :: dp(:)  !! p_b - p_a
            type(holosym_status_t), intent(out) :: status !! non-finite user values
        end subroutine increments_interface

        subroutine node_interface(self, x, i, q)
            import :: step_scheme, wp
            class(step_scheme), intent(in) :: self
            real(wp), intent(in) :: x(:)   !! solution of the bound step
            integer, intent(in) :: i       !! node index, 0..M
            real(wp), intent(out) :: q(:)  !! q_i
        end subroutine node_interface

        subroutine multipliers_interface(self, x, lambda)
            import :: step_scheme, wp
            class(step_scheme), intent(in) :: self
            real(wp), intent(in) :: x(:)            !! solution of the bound step
            real(wp), intent(out) :: lambda(:, 0:)  !! m x (0:M)
        end subroutine multipliers_interface

        function jump_interface(self, x, dp) result(jump)
            import :: step_scheme, wp
            class(step_scheme), intent(in) :: self
            real(wp), intent(in) :: x(:)   !! solution of the bound step
            real(wp), intent(in) :: dp(:)  !! p_b - p_a
            real(wp) :: jump
        end function jump_interface

        subroutine dense_interface(self, x, qa, pa, h, tau, q, p, lambda)
            import :: step_scheme, wp
            class(step_scheme), intent(in) :: self
            real(wp), intent(in) :: x(:)          !! solution of the step
            real(wp), intent(in) :: qa(:), pa(:)  !! its start state
            real(wp), intent(in) :: h             !! its step size
            real(wp), intent(in) :: tau           !! normalised time t/h
            real(wp), intent(out) :: q(:), p(:), lambda(:)
        end subroutine dense_interface

        function work_interface(self) result(counters)
            import :: step_scheme, scheme_counters_t
            class(step_scheme), intent(in) :: self
            type(scheme_counters_t) :: counters
        end function work_interface
    end interface

end module holosym_step_scheme
