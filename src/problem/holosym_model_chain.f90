!> category: internal module (use holosym)
!! A chain of K planar pendula: the scaling test case, and with K = 2 the double pendulum.
!!
!! Point masses m_k at r_k = (x_k, y_k), k = 1..K, joined by rods of lengths l_k: the first
!! to the origin, each other to the previous mass. Uniform gravity g along -y.
!!     q = (x_1, y_1, ..., x_K, y_K),   H = sum_k |p_k|^2 / (2 m_k) + g sum_k m_k y_k,
!!     phi_k = |r_k - r_(k-1)|^2 - l_k^2   (r_0 = 0).
!! Besides H, its gradients, phi and Phi, the model says what it has: a constant diagonal
!! mass matrix, the sparsity of Phi (constraint k involves bodies k-1 and k) and a
!! potential linear in q (no second derivatives), so the reduced step solves banded
!! systems and its cost grows linearly with K.
module holosym_model_chain
    use holosym_kinds, only: wp, dp
    use holosym_problem, only: constrained_hamiltonian
    implicit none
    private

    public :: pendulum_chain

    !> K planar pendula in a chain (n = 2K coordinates, m = K constraints).
    type, extends(constrained_hamiltonian) :: pendulum_chain
        real(wp), allocatable :: masses(:)   !! m_k [kg], K
        real(wp), allocatable :: lengths(:)  !! l_k [m], K
        real(wp) :: gravity = 1              !! g [m/s^2], along -y
    contains
        procedure :: hamiltonian => chain_hamiltonian
        procedure :: dh_dq => chain_dh_dq
        procedure :: dh_dp => chain_dh_dp
        !> dH/dq in real64 arithmetic.
        procedure :: dh_dq_double => chain_dh_dq_double
        procedure :: constraint => chain_constraint
        procedure :: constraint_jacobian => chain_constraint_jacobian
        !> Exact second derivatives of H (all zero but d2H/dp2 = M^-1).
        procedure :: hessian => chain_hessian
        !> Exact second derivatives of phi.
        procedure :: constraint_hessian => chain_constraint_hessian
        procedure :: diagonal_mass => chain_diagonal_mass
        procedure :: constraint_sparsity => chain_constraint_sparsity
        procedure :: constraint_jacobian_values => chain_constraint_values
        procedure :: potential_sparsity => chain_potential_sparsity
        !> State from the link angles (from the downward vertical) and angular velocities.
        procedure :: state_from_angles => chain_state_from_angles
    end type pendulum_chain

    interface pendulum_chain
        module procedure new_pendulum_chain
    end interface pendulum_chain

contains

    !> A chain of `links` pendula; masses and lengths default to 1 (arrays repeated
    !! cyclically along the chain: one value for all links, or one per link), gravity to 1. The double pendulum of masses 1 and 2 and rods 1 and 0.7:
    !! `pendulum_chain(2, masses=[1.0_wp, 2.0_wp], lengths=[1.0_wp, 0.7_wp])`.
    pure function new_pendulum_chain(links, masses, lengths, gravity) result(sys)
        integer, intent(in) :: links                 !! K >= 1
        real(wp), intent(in), optional :: masses(:)  !! m_k, repeated cyclically (not empty)
        real(wp), intent(in), optional :: lengths(:) !! l_k, repeated cyclically (not empty)
        real(wp), intent(in), optional :: gravity    !! g
        type(pendulum_chain) :: sys
        sys%n = 2 * links
        sys%m = links
        allocate (sys%masses(links), sys%lengths(links))
        sys%masses = 1
        sys%lengths = 1
        if (present(masses)) then
            if (size(masses) > 0) sys%masses = spread_or_copy(masses, links)
        end if
        if (present(lengths)) then
            if (size(lengths) > 0) sys%lengths = spread_or_copy(lengths, links)
        end if
        if (present(gravity)) sys%gravity = gravity
    contains
        pure function spread_or_copy(values, count) result(out)
            real(wp), intent(in) :: values(:)
            integer, intent(in) :: count
            real(wp) :: out(count)
            integer :: k
            do k = 1, count
                out(k) = values(mod(k - 1, size(values)) + 1)
            end do
        end function spread_or_copy
    end function new_pendulum_chain

    function chain_hamiltonian(self, q, p) result(energy)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        integer :: k
        energy = 0
        do k = 1, self%m
            energy = energy + (p(2 * k - 1)**2 + p(2 * k)**2) / (2 * self%masses(k)) &
                + self%gravity * self%masses(k) * q(2 * k)
        end do
    end function chain_hamiltonian

    subroutine chain_dh_dq(self, q, p, gradient)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        integer :: k
        do k = 1, self%m
            gradient(2 * k - 1) = 0
            gradient(2 * k) = self%gravity * self%masses(k)
        end do
    end subroutine chain_dh_dq

    subroutine chain_dh_dq_double(self, q, p, gradient)
        class(pendulum_chain), intent(in) :: self
        real(dp), intent(in) :: q(:), p(:)
        real(dp), intent(out) :: gradient(:)
        integer :: k
        do k = 1, self%m
            gradient(2 * k - 1) = 0
            gradient(2 * k) = real(self%gravity * self%masses(k), dp)
        end do
    end subroutine chain_dh_dq_double

    subroutine chain_dh_dp(self, q, p, gradient)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        integer :: k
        do k = 1, self%m
            gradient(2 * k - 1:2 * k) = p(2 * k - 1:2 * k) / self%masses(k)
        end do
    end subroutine chain_dh_dp

    !> r_k - r_(k-1) (r_0 = 0).
    pure function link(q, k) result(d)
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: k
        real(wp) :: d(2)
        d = q(2 * k - 1:2 * k)
        if (k > 1) d = d - q(2 * k - 3:2 * k - 2)
    end function link

    subroutine chain_constraint(self, q, phi)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        real(wp) :: d(2)
        integer :: k
        do k = 1, self%m
            d = link(q, k)
            phi(k) = d(1)**2 + d(2)**2 - self%lengths(k)**2
        end do
    end subroutine chain_constraint

    subroutine chain_constraint_jacobian(self, q, jacobian)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        real(wp) :: d(2)
        integer :: k
        jacobian = 0
        do k = 1, self%m
            d = link(q, k)
            jacobian(k, 2 * k - 1:2 * k) = 2 * d
            if (k > 1) jacobian(k, 2 * k - 3:2 * k - 2) = -2 * d
        end do
    end subroutine chain_constraint_jacobian

    subroutine chain_hessian(self, q, p, hqq, hqp, hpp)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        integer :: i
        hqq = 0
        hqp = 0
        hpp = 0
        do i = 1, self%n
            hpp(i, i) = 1 / self%masses((i + 1) / 2)
        end do
    end subroutine chain_hessian

    subroutine chain_constraint_hessian(self, q, hessian)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        integer :: k, c
        hessian = 0
        do k = 1, self%m
            do c = 0, 1
                hessian(2 * k - 1 + c, 2 * k - 1 + c, k) = 2
                if (k > 1) then
                    hessian(2 * k - 3 + c, 2 * k - 3 + c, k) = 2
                    hessian(2 * k - 1 + c, 2 * k - 3 + c, k) = -2
                    hessian(2 * k - 3 + c, 2 * k - 1 + c, k) = -2
                end if
            end do
        end do
    end subroutine chain_constraint_hessian

    logical function chain_diagonal_mass(self, mass) result(declared)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        integer :: k
        do k = 1, self%m
            mass(2 * k - 1:2 * k) = self%masses(k)
        end do
        declared = .true.
    end function chain_diagonal_mass

    !> Constraint k: the entries of body k (x_k, y_k) and, for k > 1, of body k-1.
    subroutine chain_constraint_sparsity(self, rows, columns)
        class(pendulum_chain), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        integer :: k, e
        allocate (rows(4 * self%m - 2), columns(4 * self%m - 2))
        e = 0
        do k = 1, self%m
            rows(e + 1:e + 2) = k
            columns(e + 1:e + 2) = [2 * k - 1, 2 * k]
            e = e + 2
            if (k > 1) then
                rows(e + 1:e + 2) = k
                columns(e + 1:e + 2) = [2 * k - 3, 2 * k - 2]
                e = e + 2
            end if
        end do
    end subroutine chain_constraint_sparsity

    !> The values of Phi in the order of `chain_constraint_sparsity`.
    subroutine chain_constraint_values(self, q, rows, columns, values)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(out) :: values(:)
        real(wp) :: d(2)
        integer :: k, e
        e = 0
        do k = 1, self%m
            d = link(q, k)
            values(e + 1:e + 2) = 2 * d
            e = e + 2
            if (k > 1) then
                values(e + 1:e + 2) = -2 * d
                e = e + 2
            end if
        end do
    end subroutine chain_constraint_values

    !> U = g sum_k m_k y_k is linear: no second derivatives.
    subroutine chain_potential_sparsity(self, rows, columns)
        class(pendulum_chain), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        allocate (rows(0), columns(0))
    end subroutine chain_potential_sparsity

    !> A state on the constraint manifold from link angles theta_k (from the downward
    !! vertical) and angular velocities omega_k.
    pure subroutine chain_state_from_angles(self, theta, omega, q, p)
        class(pendulum_chain), intent(in) :: self
        real(wp), intent(in) :: theta(:)  !! link angles (K)
        real(wp), intent(in) :: omega(:)  !! angular velocities (K)
        real(wp), intent(out) :: q(:)     !! coordinates (2K)
        real(wp), intent(out) :: p(:)     !! momenta (2K)
        real(wp) :: r(2), v(2)
        integer :: k
        r = 0
        v = 0
        do k = 1, self%m
            r = r + self%lengths(k) * [sin(theta(k)), -cos(theta(k))]
            v = v + self%lengths(k) * omega(k) * [cos(theta(k)), sin(theta(k))]
            q(2 * k - 1:2 * k) = r
            p(2 * k - 1:2 * k) = self%masses(k) * v
        end do
    end subroutine chain_state_from_angles

end module holosym_model_chain
