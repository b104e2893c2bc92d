!> category: internal module (use holosym)
!! The competitor: RATTLE (second order, symmetric, symplectic, both constraint levels
!! at the step ends) for the same problem interface, raised to orders 4, 6, 8 and 10 by
!! symmetric composition, as in Hairer's GNI_COMP.
!!
!! One RATTLE step of size t from (q0, p0) (general H: the Lobatto IIIA-IIIB pair):
!!
!!     p' = p0 - t/2 (H_q(q0, p') + Phi(q0)^T lambda)
!!     q1 = q0 + t/2 (H_p(q0, p') + H_p(q1, p')),     phi(q1) = 0
!!     p1 = p' - t/2 (H_q(q1, p') + Phi(q1)^T mu),   Phi(q1) H_p(q1, p1) = 0
!!
!! The first line and phi(q1) = 0 are solved by Newton's method for (p', q1, lambda);
!! with `separable = .true.` (H = T(p) + U(q), as in the three models) p' and q1 are
!! explicit in lambda and Newton runs on lambda alone (m unknowns), and the force
!! U_q(q1), Phi(q1) of one substep is reused by the next. The hidden constraint is solved
!! for mu by Newton (m unknowns; one step when T is quadratic). Every Newton iteration
!! uses exact second derivatives from the system's `hessian`/`constraint_hessian`
!! bindings and runs to the working-precision tolerance.
!!
!! Compositions (holosym_compositions, coefficients exact to working precision):
!! - 'triple-jump': Psi_{p+2}(h) = Psi_p(g1 h) Psi_p(g2 h) Psi_p(g1 h),
!!   g1 = 1/(2 - 2^(1/(p+1))), g2 = 1 - 2 g1; 3^(p/2-1) RATTLE steps for order p.
!! - 'suzuki': Psi_{p+2}(h) = Psi_p(g1 h)^2 Psi_p(g3 h) Psi_p(g1 h)^2,
!!   g1 = 1/(4 - 4^(1/(p+1))), g3 = 1 - 4 g1; 5^(p/2-1) steps, smaller error constants.
!! - GNI_COMP's optimised compositions: 'yoshida' (order 6, 7 steps), 'kahan-li'
!!   (6: 9 steps, 8: 17), 'suzuki-umeno' (8: 15), 'hlw' (10: 33), 'sofroniou-spaletta'
!!   (10: 33), far more efficient than the fractal constructions at orders 8 and 10.
module holosym_rattle
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_NOT_INITIALIZED, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_STEP_SIZE, &
        HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, &
        HOLOSYM_NONFINITE_VALUE, HOLOSYM_INVALID_DIMENSION
    use holosym_problem, only: constrained_hamiltonian
    use holosym_linalg, only: lu_factor, lu_solve
    use holosym_compositions, only: composition_coefficients, composition_max_order
    implicit none
    private

    public :: rattle_integrator, rattle_stats_t, composition_coefficients

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Largest composition order.
    integer, parameter, public :: rattle_max_order = composition_max_order

    !> Work done by a RATTLE integrator since `init`.
    type :: rattle_stats_t
        !> Composed steps.
        integer(int64) :: steps = 0
        !> RATTLE substeps.
        integer(int64) :: substeps = 0
        !> Newton iterations (both stages).
        integer(int64) :: newton_iterations = 0
        !> Calls of dh_dq or dh_dp.
        integer(int64) :: gradient_evaluations = 0
        !> Calls of hessian or constraint_hessian.
        integer(int64) :: hessian_evaluations = 0
        !> LU factorisations (of the small Newton matrices).
        integer(int64) :: lu_factorizations = 0
    end type rattle_stats_t

    !> RATTLE composed to order 2, 4, 6, 8 or 10.
    type :: rattle_integrator
        !> H = T(p) + U(q): explicit stages, Newton on the multipliers only.
        logical :: separable = .false.
        !> Newton stops when the correction is below tolerance * max(1, |unknowns|).
        real(wp) :: tolerance = 8 * eps
        !> Newton iteration limit per stage.
        integer :: max_iterations = 50
        !> Work counters.
        type(rattle_stats_t) :: stats
        !> Substep fractions gamma_k (summing to 1).
        real(wp), allocatable :: gammas(:)
        integer, private :: order = 0
        integer, private :: n = 0, m = 0
        logical, private :: ready = .false.
        ! Force at the current state (separable FSAL): U_q(q), Phi(q) valid for q_cached.
        logical, private :: have_force = .false.
        real(wp), allocatable, private :: q_cached(:), force(:), phi_jac(:, :)
        real(wp), allocatable, private :: lambda(:), mu(:)
        ! Workspace.
        real(wp), allocatable, private :: p_half(:), q1(:), grad(:), grad2(:), velocity(:)
        real(wp), allocatable, private :: phi(:), phi_jac1(:, :), delta(:, :), small(:, :)
        real(wp), allocatable, private :: hqq(:, :), hqp(:, :), hpp(:, :), hpp2(:, :), hqp2(:, :)
        real(wp), allocatable, private :: tmp(:, :), phi_hess(:, :, :)
        real(wp), allocatable, private :: big(:, :), big_rhs(:, :), y(:)
        integer, allocatable, private :: pivots(:), big_pivots(:)
    contains
        !> Set up for a system, an order and a composition family.
        procedure :: init => rattle_init
        !> One composed step of size h, in place.
        procedure :: step => rattle_step
        !> Many composed steps.
        procedure :: integrate => rattle_integrate
        !> Number of RATTLE substeps per step.
        procedure :: stages => rattle_stages
    end type rattle_integrator

contains

    !> Set up for `sys` (sizes n, m), composition order and family.
    !! Codes: those of `composition_coefficients`, HOLOSYM_INVALID_DIMENSION (n < 1, m < 0,
    !! m >= n, or a dense workspace beyond the default integer).
    subroutine rattle_init(self, sys, order, family, status)
        class(rattle_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system (n, m are read)
        integer, intent(in) :: order            !! 2, 4, 6, 8 or 10 (as the family has)
        character(len=*), intent(in) :: family  !! a family of holosym_compositions
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        integer :: n, m
        call composition_coefficients(order, family, self%gammas, local)
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        n = sys%n
        m = sys%m
        if (n < 1 .or. m < 0 .or. m >= n) then
            self%ready = .false.
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "need n >= 1 and 0 <= m < n; " &
                // "got n = " // int_str(n) // ", m = " // int_str(m))
            return
        end if
        ! The dense workspace: (2n + m)^2 and n^2 m entries.
        if ((2 * int(n, int64) + m)**2 > huge(0) .or. int(n, int64)**2 * max(m, 1) > huge(0)) then
            self%ready = .false.
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "n = " // int_str(n) // &
                ", m = " // int_str(m) // " is too large for the dense workspace of RATTLE")
            return
        end if
        self%order = order
        self%n = n
        self%m = m
        if (allocated(self%q_cached)) deallocate (self%q_cached, self%force, self%phi_jac, &
            self%lambda, self%mu, self%p_half, self%q1, self%grad, self%grad2, self%velocity, &
            self%phi, self%phi_jac1, self%delta, self%small, self%hqq, self%hqp, self%hpp, &
            self%hpp2, self%hqp2, self%tmp, self%phi_hess, self%big, self%big_rhs, self%y, &
            self%pivots, &
            self%big_pivots)
        allocate (self%q_cached(n), self%force(n), self%phi_jac(m, n), self%lambda(m), &
                  self%mu(m), self%p_half(n), self%q1(n), self%grad(n), self%grad2(n), &
                  self%velocity(n), self%phi(m), self%phi_jac1(m, n), self%delta(m, 1), &
                  self%small(m, m), self%hqq(n, n), self%hqp(n, n), self%hpp(n, n), &
                  self%hpp2(n, n), self%hqp2(n, n), self%tmp(m, n), self%phi_hess(n, n, m), &
                  self%big(2 * n + m, 2 * n + m), self%big_rhs(2 * n + m, 1), &
                  self%y(2 * n + m), self%pivots(m), self%big_pivots(2 * n + m))
        self%lambda = 0
        self%mu = 0
        self%have_force = .false.
        self%stats = rattle_stats_t()
        self%ready = .true.
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine rattle_init

    !> RATTLE substeps per composed step.
    pure integer function rattle_stages(self)
        class(rattle_integrator), intent(in) :: self
        rattle_stages = 0
        if (allocated(self%gammas)) rattle_stages = size(self%gammas)
    end function rattle_stages

    !> One composed step of size h; q, p unchanged on failure.
    !! Codes: HOLOSYM_NOT_INITIALIZED, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_STEP_SIZE,
    !! HOLOSYM_INVALID_ARGUMENT (tolerance outside (0, 1) or max_iterations < 1),
    !! HOLOSYM_SINGULAR_MATRIX, HOLOSYM_NEWTON_NOT_CONVERGED, HOLOSYM_NONFINITE_VALUE.
    subroutine rattle_step(self, sys, q, p, h, status)
        class(rattle_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(inout) :: q(:) !! coordinates in/out
        real(wp), intent(inout) :: p(:) !! momenta in/out
        real(wp), intent(in) :: h       !! step size > 0
        type(holosym_status_t), intent(out), optional :: status !! outcome
        call rattle_integrate(self, sys, q, p, h, 1, status)
    end subroutine rattle_step

    !> `steps` composed steps of size h. On failure q, p hold the last completed step.
    !! Codes: those of `step`, and HOLOSYM_INVALID_STEP_COUNT.
    subroutine rattle_integrate(self, sys, q, p, h, steps, status)
        class(rattle_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(inout) :: q(:) !! coordinates in/out
        real(wp), intent(inout) :: p(:) !! momenta in/out
        real(wp), intent(in) :: h       !! step size > 0
        integer, intent(in) :: steps    !! number of steps >= 0
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        real(wp) :: q_start(size(q)), p_start(size(p))
        integer :: k, s

        if (.not. self%ready) then
            call set_status(status, HOLOSYM_NOT_INITIALIZED, "call init before step")
            return
        else if (size(q) /= self%n .or. size(p) /= self%n .or. sys%n /= self%n .or. &
                 sys%m /= self%m) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q, p and the system must have " // &
                "the sizes given to init (n = " // int_str(self%n) // ")")
            return
        else if (.not. is_finite(h)) then
            call set_status(status, HOLOSYM_INVALID_STEP_SIZE, "step size must be positive " // &
                "and finite; got h = " // real_str(h))
            return
        else if (h <= 0) then
            call set_status(status, HOLOSYM_INVALID_STEP_SIZE, "step size must be positive " // &
                "and finite; got h = " // real_str(h))
            return
        else if (steps < 0) then
            call set_status(status, HOLOSYM_INVALID_STEP_COUNT, "step count must be >= 0; " // &
                "got " // int_str(steps))
            return
        else if (self%max_iterations < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "max_iterations must be >= 1; " &
                // "got " // int_str(self%max_iterations))
            return
        else if (.not. is_finite(self%tolerance)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tolerance must be in (0, 1); " &
                // "got " // real_str(self%tolerance))
            return
        else if (self%tolerance <= 0 .or. self%tolerance >= 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "tolerance must be in (0, 1); " &
                // "got " // real_str(self%tolerance))
            return
        end if
        local%code = HOLOSYM_SUCCESS
        do k = 1, steps
            q_start = q
            p_start = p
            do s = 1, size(self%gammas)
                call substep(self, sys, q, p, self%gammas(s) * h, local)
                if (.not. local%ok()) then
                    q = q_start
                    p = p_start
                    self%have_force = .false.
                    call set_status(status, local%code, "after " // int_str(k - 1) // &
                        " steps: " // local%message)
                    return
                end if
            end do
            self%stats%steps = self%stats%steps + 1
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine rattle_integrate

    !> One RATTLE step of size t (may be negative) in place.
    subroutine substep(self, sys, q, p, t, status)
        class(rattle_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(inout) :: q(:), p(:)
        real(wp), intent(in) :: t
        type(holosym_status_t), intent(inout) :: status
        integer :: m

        m = self%m
        self%stats%substeps = self%stats%substeps + 1
        ! lambda starts from the last multiplier (both approximate lambda(t0)).
        self%lambda = self%mu
        if (self%separable) then
            call separable_first_half(self, sys, q, p, t, status)
        else
            call general_first_half(self, sys, q, p, t, status)
        end if
        if (.not. status%ok()) return
        ! Second half: p1 = p' - t/2 (H_q(q1, p') + Phi1^T mu), Phi1 H_p(q1, p1) = 0.
        call sys%dh_dq(self%q1, self%p_half, self%grad2)
        self%stats%gradient_evaluations = self%stats%gradient_evaluations + 1
        if (m > 0) call sys%constraint_jacobian(self%q1, self%phi_jac1)
        call solve_mu(self, sys, t, status)
        if (.not. status%ok()) return
        q = self%q1
        ! p1 = p' - t/2 (H_q + Phi1^T mu)
        call kick(p, self%p_half, t / 2, self%grad2, self%phi_jac1, self%mu)
        if (.not. (all(is_finite(q)) .and. all(is_finite(p)))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "RATTLE produced a non-finite state")
            return
        end if
        if (self%separable) then
            ! First same as last: U_q(q1) and Phi(q1) start the next substep.
            self%q_cached = q
            self%force = self%grad2
            self%phi_jac = self%phi_jac1
            self%have_force = .true.
        end if
    end subroutine substep

    !> target = base - factor (force + Phi^T v) for Phi (m x n), without temporaries.
    pure subroutine kick(target, base, factor, force, phi_jac, v)
        real(wp), intent(out) :: target(:)
        real(wp), intent(in) :: base(:), factor, force(:), phi_jac(:, :), v(:)
        integer :: l
        target = force
        do l = 1, size(v)
            target = target + v(l) * phi_jac(l, :)
        end do
        target = base - factor * target
    end subroutine kick

    !> Separable first half: Newton on lambda for phi(q1(lambda)) = 0 with
    !! p' = p0 - t/2 (U_q(q0) + Phi0^T lambda), q1 = q0 + t T_p(p').
    subroutine separable_first_half(self, sys, q, p, t, status)
        class(rattle_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), t
        type(holosym_status_t), intent(inout) :: status
        integer :: iter, info, m, l, k
        real(wp) :: correction, previous

        m = self%m
        if (.not. (self%have_force .and. all(q == self%q_cached))) then
            call sys%dh_dq(q, p, self%force)
            self%stats%gradient_evaluations = self%stats%gradient_evaluations + 1
            if (m > 0) call sys%constraint_jacobian(q, self%phi_jac)
        end if
        previous = huge(1.0_wp)
        do iter = 1, self%max_iterations
            self%stats%newton_iterations = self%stats%newton_iterations + 1
            call kick(self%p_half, p, t / 2, self%force, self%phi_jac, self%lambda)
            call sys%dh_dp(q, self%p_half, self%velocity)
            self%stats%gradient_evaluations = self%stats%gradient_evaluations + 1
            self%q1 = q + t * self%velocity
            if (m == 0) exit
            call sys%constraint(self%q1, self%phi)
            if (.not. (all(is_finite(self%phi)) .and. all(is_finite(self%q1)))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "non-finite value in RATTLE")
                return
            end if
            ! d phi(q1)/d lambda = -t^2/2 Phi(q1) T_pp(p') Phi0^T.
            call sys%constraint_jacobian(self%q1, self%phi_jac1)
            call sys%hessian(q, self%p_half, self%hqq, self%hqp, self%hpp)
            self%stats%hessian_evaluations = self%stats%hessian_evaluations + 1
            do k = 1, self%n
                do l = 1, m
                    self%tmp(l, k) = sum(self%phi_jac1(l, :) * self%hpp(:, k))
                end do
            end do
            do k = 1, m
                do l = 1, m
                    self%small(l, k) = -t * t / 2 * sum(self%tmp(l, :) * self%phi_jac(k, :))
                end do
            end do
            self%delta(:, 1) = self%phi
            call lu_factor(self%small, self%pivots, info)
            self%stats%lu_factorizations = self%stats%lu_factorizations + 1
            if (info /= 0) then
                call set_status(status, HOLOSYM_SINGULAR_MATRIX, "RATTLE multiplier matrix " // &
                    "singular (step too small or constraints dependent)")
                return
            end if
            call lu_solve(self%small, self%pivots, self%delta)
            self%lambda = self%lambda - self%delta(:, 1)
            correction = maxval(abs(self%delta(:, 1))) / max(1.0_wp, maxval(abs(self%lambda)))
            if (correction <= self%tolerance) then
                ! Recompute p', q1 with the final lambda.
                call kick(self%p_half, p, t / 2, self%force, self%phi_jac, self%lambda)
                call sys%dh_dp(q, self%p_half, self%velocity)
                self%stats%gradient_evaluations = self%stats%gradient_evaluations + 1
                self%q1 = q + t * self%velocity
                return
            end if
            if (correction >= previous .and. correction <= eps**(2.0_wp / 3)) then
                call kick(self%p_half, p, t / 2, self%force, self%phi_jac, self%lambda)
                call sys%dh_dp(q, self%p_half, self%velocity)
                self%stats%gradient_evaluations = self%stats%gradient_evaluations + 1
                self%q1 = q + t * self%velocity
                return
            end if
            previous = correction
        end do
        if (m > 0) call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "RATTLE multipliers " &
            // "not converged in " // int_str(self%max_iterations) // " iterations")
    end subroutine separable_first_half

    !> General first half: Newton on y = (p', q1, lambda) for
    !!   p' - p0 + t/2 (H_q(q0, p') + Phi0^T lambda) = 0,
    !!   q1 - q0 - t/2 (H_p(q0, p') + H_p(q1, p')) = 0,   phi(q1) = 0.
    subroutine general_first_half(self, sys, q, p, t, status)
        class(rattle_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:), t
        type(holosym_status_t), intent(inout) :: status
        integer :: iter, info, n, m, i, l
        real(wp) :: correction, previous

        n = self%n
        m = self%m
        if (m > 0) call sys%constraint_jacobian(q, self%phi_jac)
        ! First guess: explicit Euler-like half step.
        self%p_half = p
        self%q1 = q
        previous = huge(1.0_wp)
        do iter = 1, self%max_iterations
            self%stats%newton_iterations = self%stats%newton_iterations + 1
            call sys%dh_dq(q, self%p_half, self%grad)
            call sys%dh_dp(q, self%p_half, self%velocity)
            call sys%dh_dp(self%q1, self%p_half, self%grad2)
            self%stats%gradient_evaluations = self%stats%gradient_evaluations + 3
            call kick(self%big_rhs(1:n, 1), self%p_half, -t / 2, self%grad, self%phi_jac, &
                      self%lambda)
            self%big_rhs(1:n, 1) = self%big_rhs(1:n, 1) - p
            self%big_rhs(n + 1:2 * n, 1) = self%q1 - q - t / 2 * (self%velocity + self%grad2)
            if (m > 0) call sys%constraint(self%q1, self%big_rhs(2 * n + 1:2 * n + m, 1))
            if (.not. all(is_finite(self%big_rhs))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "non-finite value in RATTLE")
                return
            end if
            ! Jacobian with respect to (p', q1, lambda).
            self%big = 0
            call sys%hessian(q, self%p_half, self%hqq, self%hqp, self%hpp)
            call sys%hessian(self%q1, self%p_half, self%hqq, self%hqp2, self%hpp2)
            self%stats%hessian_evaluations = self%stats%hessian_evaluations + 2
            do i = 1, n
                self%big(i, i) = 1
                self%big(n + i, n + i) = 1
            end do
            ! d r1/d p' = I + t/2 H_qp(q0, p'); d r1/d lambda = t/2 Phi0^T.
            self%big(1:n, 1:n) = self%big(1:n, 1:n) + t / 2 * self%hqp
            do l = 1, m
                self%big(1:n, 2 * n + l) = t / 2 * self%phi_jac(l, :)
            end do
            ! d r2/d p' = -t/2 (H_pp(q0, p') + H_pp(q1, p')); d r2/d q1 = I - t/2 H_pq(q1, p').
            self%big(n + 1:2 * n, 1:n) = -t / 2 * (self%hpp + self%hpp2)
            self%big(n + 1:2 * n, n + 1:2 * n) = self%big(n + 1:2 * n, n + 1:2 * n) &
                - t / 2 * transpose(self%hqp2)
            if (m > 0) then
                call sys%constraint_jacobian(self%q1, self%phi_jac1)
                self%big(2 * n + 1:2 * n + m, n + 1:2 * n) = self%phi_jac1
            end if
            call lu_factor(self%big, self%big_pivots, info)
            self%stats%lu_factorizations = self%stats%lu_factorizations + 1
            if (info /= 0) then
                call set_status(status, HOLOSYM_SINGULAR_MATRIX, "RATTLE stage matrix singular")
                return
            end if
            call lu_solve(self%big, self%big_pivots, self%big_rhs)
            self%p_half = self%p_half - self%big_rhs(1:n, 1)
            self%q1 = self%q1 - self%big_rhs(n + 1:2 * n, 1)
            self%lambda = self%lambda - self%big_rhs(2 * n + 1:2 * n + m, 1)
            correction = maxval(abs(self%big_rhs(:, 1))) / max(1.0_wp, maxval(abs(q)), &
                maxval(abs(p)), maxval(abs(self%lambda)))
            if (correction <= self%tolerance) return
            if (correction >= previous .and. correction <= eps**(2.0_wp / 3)) return
            previous = correction
        end do
        call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "RATTLE stage not converged in " &
            // int_str(self%max_iterations) // " iterations")
    end subroutine general_first_half

    !> Newton on mu for Phi1 H_p(q1, p1(mu)) = 0, p1 = p' - t/2 (grad2 + Phi1^T mu).
    subroutine solve_mu(self, sys, t, status)
        class(rattle_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: t
        type(holosym_status_t), intent(inout) :: status
        integer :: iter, info, m, l, k
        real(wp) :: correction, previous
        m = self%m
        if (m == 0) return
        previous = huge(1.0_wp)
        do iter = 1, self%max_iterations
            self%stats%newton_iterations = self%stats%newton_iterations + 1
            call kick(self%grad, self%p_half, t / 2, self%grad2, self%phi_jac1, self%mu)
            call sys%dh_dp(self%q1, self%grad, self%velocity)
            self%stats%gradient_evaluations = self%stats%gradient_evaluations + 1
            do l = 1, m
                self%delta(l, 1) = sum(self%phi_jac1(l, :) * self%velocity)
            end do
            if (.not. all(is_finite(self%delta))) then
                call set_status(status, HOLOSYM_NONFINITE_VALUE, "non-finite value in RATTLE")
                return
            end if
            ! d/d mu = -t/2 Phi1 H_pp(q1, p1) Phi1^T.
            call sys%hessian(self%q1, self%grad, self%hqq, self%hqp, self%hpp)
            self%stats%hessian_evaluations = self%stats%hessian_evaluations + 1
            do k = 1, self%n
                do l = 1, m
                    self%tmp(l, k) = sum(self%phi_jac1(l, :) * self%hpp(:, k))
                end do
            end do
            do k = 1, m
                do l = 1, m
                    self%small(l, k) = -t / 2 * sum(self%tmp(l, :) * self%phi_jac1(k, :))
                end do
            end do
            call lu_factor(self%small, self%pivots, info)
            self%stats%lu_factorizations = self%stats%lu_factorizations + 1
            if (info /= 0) then
                call set_status(status, HOLOSYM_SINGULAR_MATRIX, "RATTLE velocity multiplier " &
                    // "matrix singular")
                return
            end if
            call lu_solve(self%small, self%pivots, self%delta)
            self%mu = self%mu - self%delta(:, 1)
            correction = maxval(abs(self%delta(:, 1))) / max(1.0_wp, maxval(abs(self%mu)))
            if (correction <= self%tolerance) return
            if (correction >= previous .and. correction <= eps**(2.0_wp / 3)) return
            previous = correction
        end do
        call set_status(status, HOLOSYM_NEWTON_NOT_CONVERGED, "RATTLE velocity multipliers " // &
            "not converged in " // int_str(self%max_iterations) // " iterations")
    end subroutine solve_mu

end module holosym_rattle
