!> category: internal module (use holosym)
!! The problem interface: a Hamiltonian system with holonomic constraints.
!!
!! A user defines a system by extending `constrained_hamiltonian`, setting the sizes
!! `n` (coordinates) and `m` (constraints), and implementing five procedures:
!! H(q,p), dH/dq, dH/dp, phi(q) and Phi(q) = dphi/dq. Parameters of the system are
!! components of the extended type. Second derivatives (`hessian`,
!! `constraint_hessian`) are optional: the defaults use central differences of the
!! first derivatives, accurate to about epsilon**(2/3) relative, which is enough for
!! Newton's method to converge to full precision.
!!
!! Equations of motion: q' = dH/dp, p' = -dH/dq - Phi(q)^T lambda, phi(q) = 0.
module holosym_problem
    use holosym_kinds, only: wp
    implicit none
    private

    public :: constrained_hamiltonian, difference_hessian, difference_constraint_hessian


    !> Abstract constrained Hamiltonian system. Extend it and implement the deferred bindings.
    type, abstract :: constrained_hamiltonian
        !> Number of coordinates q (and momenta p), n >= 1.
        integer :: n = 0
        !> Number of holonomic constraints, 0 <= m < n.
        integer :: m = 0
    contains
        !> H(q, p).
        procedure(hamiltonian_interface), deferred :: hamiltonian
        !> dH/dq(q, p), size n.
        procedure(gradient_interface), deferred :: dh_dq
        !> dH/dp(q, p), size n.
        procedure(gradient_interface), deferred :: dh_dp
        !> phi(q), size m.
        procedure(constraint_interface), deferred :: constraint
        !> Phi(q) = dphi/dq, m x n: Phi(l, i) = d phi_l / d q_i.
        procedure(constraint_jacobian_interface), deferred :: constraint_jacobian
        !> Second derivatives of H (optional; default: central differences of the gradients).
        procedure :: hessian => difference_hessian
        !> Second derivatives of phi (optional; default: central differences of Phi).
        procedure :: constraint_hessian => difference_constraint_hessian
    end type constrained_hamiltonian

    abstract interface
        !> Value of the Hamiltonian.
        function hamiltonian_interface(self, q, p) result(energy)
            import :: constrained_hamiltonian, wp
            class(constrained_hamiltonian), intent(in) :: self !! the system
            real(wp), intent(in) :: q(:) !! coordinates (n)
            real(wp), intent(in) :: p(:) !! momenta (n)
            real(wp) :: energy
        end function hamiltonian_interface

        !> A gradient of the Hamiltonian (with respect to q or to p).
        subroutine gradient_interface(self, q, p, gradient)
            import :: constrained_hamiltonian, wp
            class(constrained_hamiltonian), intent(in) :: self !! the system
            real(wp), intent(in) :: q(:)         !! coordinates (n)
            real(wp), intent(in) :: p(:)         !! momenta (n)
            real(wp), intent(out) :: gradient(:) !! the gradient (n)
        end subroutine gradient_interface

        !> Constraint values phi(q).
        subroutine constraint_interface(self, q, phi)
            import :: constrained_hamiltonian, wp
            class(constrained_hamiltonian), intent(in) :: self !! the system
            real(wp), intent(in) :: q(:)     !! coordinates (n)
            real(wp), intent(out) :: phi(:)  !! constraint values (m)
        end subroutine constraint_interface

        !> Constraint Jacobian Phi(q) = dphi/dq.
        subroutine constraint_jacobian_interface(self, q, jacobian)
            import :: constrained_hamiltonian, wp
            class(constrained_hamiltonian), intent(in) :: self !! the system
            real(wp), intent(in) :: q(:)             !! coordinates (n)
            real(wp), intent(out) :: jacobian(:, :)  !! m x n, jacobian(l, i) = dphi_l/dq_i
        end subroutine constraint_jacobian_interface
    end interface

contains

    !> Relative step of the default central differences: epsilon**(1/3) balances
    !! truncation (step**2) against round-off (epsilon/step). A function rather than a
    !! named constant because not every compiler folds real128 powers.
    pure real(wp) function difference_step()
        difference_step = epsilon(1.0_wp)**(1.0_wp / 3)
    end function difference_step

    !> Default second derivatives of H by central differences of `dh_dq` and `dh_dp`:
    !! `hqq(i,k) = d2H/dq_i dq_k`, `hqp(i,k) = d2H/dq_i dp_k`, `hpp(i,k) = d2H/dp_i dp_k`.
    !! Override it with exact derivatives for speed (6n gradient calls are saved per call).
    !! Public so that an integrator can ignore a user's `hessian` (for comparisons).
    subroutine difference_hessian(self, q, p, hqq, hqp, hpp)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)        !! coordinates (n)
        real(wp), intent(in) :: p(:)        !! momenta (n)
        real(wp), intent(out) :: hqq(:, :)  !! n x n
        real(wp), intent(out) :: hqp(:, :)  !! n x n
        real(wp), intent(out) :: hpp(:, :)  !! n x n
        real(wp) :: shifted(size(q)), plus(size(q)), minus(size(q)), step, upper, lower
        integer :: k

        do k = 1, size(q)
            ! Differencing the representable neighbours keeps the divisor exact.
            step = difference_step() * max(1.0_wp, abs(q(k)))
            upper = q(k) + step
            lower = q(k) - step
            shifted = q
            shifted(k) = upper
            call self%dh_dq(shifted, p, plus)
            shifted(k) = lower
            call self%dh_dq(shifted, p, minus)
            hqq(:, k) = (plus - minus) / (upper - lower)
        end do
        do k = 1, size(p)
            step = difference_step() * max(1.0_wp, abs(p(k)))
            upper = p(k) + step
            lower = p(k) - step
            shifted = p
            shifted(k) = upper
            call self%dh_dq(q, shifted, plus)
            shifted(k) = lower
            call self%dh_dq(q, shifted, minus)
            hqp(:, k) = (plus - minus) / (upper - lower)
            shifted(k) = upper
            call self%dh_dp(q, shifted, plus)
            shifted(k) = lower
            call self%dh_dp(q, shifted, minus)
            hpp(:, k) = (plus - minus) / (upper - lower)
        end do
    end subroutine difference_hessian

    !> Default second derivatives of the constraints by central differences of
    !! `constraint_jacobian`: `hessian(i, k, l) = d2 phi_l / dq_i dq_k` (2n Jacobian calls).
    subroutine difference_constraint_hessian(self, q, hessian)
        class(constrained_hamiltonian), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)              !! coordinates (n)
        real(wp), intent(out) :: hessian(:, :, :) !! n x n x m
        real(wp) :: shifted(size(q)), plus(self%m, size(q)), minus(self%m, size(q))
        real(wp) :: step, upper, lower
        integer :: k, l

        do k = 1, size(q)
            step = difference_step() * max(1.0_wp, abs(q(k)))
            upper = q(k) + step
            lower = q(k) - step
            shifted = q
            shifted(k) = upper
            call self%constraint_jacobian(shifted, plus)
            shifted(k) = lower
            call self%constraint_jacobian(shifted, minus)
            do l = 1, self%m
                hessian(:, k, l) = (plus(l, :) - minus(l, :)) / (upper - lower)
            end do
        end do
    end subroutine difference_constraint_hessian

end module holosym_problem
