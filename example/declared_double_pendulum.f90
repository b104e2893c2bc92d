!> A user's system with every optional declaration: a double pendulum in Cartesian
!! coordinates q = (x1, y1, x2, y2), unit masses and rods, gravity g along -y,
!!     H = |p|^2 / 2 + g (y1 + y2),   phi_1 = x1^2 + y1^2 - 1,
!!     phi_2 = (x2 - x1)^2 + (y2 - y1)^2 - 1.
!! `plain_double_pendulum` writes the five procedures every system needs;
!! `declared_double_pendulum` extends it with what makes a step cheaper, each checked by
!! the integrator against the five at its first step (docs/user_system.md lists every
!! declaration with its signature): exact second derivatives (`hessian`,
!! `constraint_hessian`), the constant diagonal mass matrix (`diagonal_mass`: the reduced
!! step), the sparsity of Phi (`constraint_sparsity` with `constraint_jacobian_values`),
!! the sparsity of the Hessian of U (`potential_sparsity`: U is linear, no entries) and
!! dH/dq in real64 (`dh_dq_double`).
module declared_double_pendulum
    use holosym, only: wp, dp, constrained_hamiltonian
    implicit none
    private

    public :: plain_double_pendulum, declared_double_pendulum_t

    !> The five procedures.
    type, extends(constrained_hamiltonian) :: plain_double_pendulum
        real(wp) :: gravity = 1 !! g
    contains
        procedure :: hamiltonian => double_hamiltonian
        procedure :: dh_dq => double_dh_dq
        procedure :: dh_dp => double_dh_dp
        procedure :: constraint => double_constraint
        procedure :: constraint_jacobian => double_jacobian
    end type plain_double_pendulum

    !> The same system with every optional declaration.
    type, extends(plain_double_pendulum) :: declared_double_pendulum_t
    contains
        procedure :: hessian => double_hessian
        procedure :: constraint_hessian => double_constraint_hessian
        procedure :: diagonal_mass => double_mass
        procedure :: constraint_sparsity => double_pattern
        procedure :: constraint_jacobian_values => double_values
        procedure :: potential_sparsity => double_potential_pattern
        procedure :: dh_dq_double => double_dh_dq_double
    end type declared_double_pendulum_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! example's module out of `fpm install` of holosym (not needed in your code).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    function double_hamiltonian(self, q, p) result(energy)
        class(plain_double_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = sum(p**2) / 2 + self%gravity * (q(2) + q(4))
    end function double_hamiltonian

    subroutine double_dh_dq(self, q, p, gradient)
        class(plain_double_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = [0.0_wp, self%gravity, 0.0_wp, self%gravity]
    end subroutine double_dh_dq

    subroutine double_dh_dp(self, q, p, gradient)
        class(plain_double_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = p
    end subroutine double_dh_dp

    subroutine double_constraint(self, q, phi)
        class(plain_double_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi(1) = q(1)**2 + q(2)**2 - 1
        phi(2) = (q(3) - q(1))**2 + (q(4) - q(2))**2 - 1
    end subroutine double_constraint

    !> Phi(l, i) = d phi_l / d q_i (m x n).
    subroutine double_jacobian(self, q, jacobian)
        class(plain_double_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian = 0
        jacobian(1, 1:2) = 2 * q(1:2)
        jacobian(2, 1:2) = -2 * (q(3:4) - q(1:2))
        jacobian(2, 3:4) = 2 * (q(3:4) - q(1:2))
    end subroutine double_jacobian

    !> hqq(i, k) = d2H/dq_i dq_k, hqp(i, k) = d2H/dq_i dp_k, hpp(i, k) = d2H/dp_i dp_k
    !! (each n x n).
    subroutine double_hessian(self, q, p, hqq, hqp, hpp)
        class(declared_double_pendulum_t), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        integer :: i
        hqq = 0
        hqp = 0
        hpp = 0
        do i = 1, 4
            hpp(i, i) = 1
        end do
    end subroutine double_hessian

    !> hessian(i, k, l) = d2 phi_l / dq_i dq_k (n x n x m).
    subroutine double_constraint_hessian(self, q, hessian)
        class(declared_double_pendulum_t), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        integer :: i
        hessian = 0
        hessian(1, 1, 1) = 2
        hessian(2, 2, 1) = 2
        do i = 1, 4
            hessian(i, i, 2) = 2
        end do
        hessian(1, 3, 2) = -2
        hessian(3, 1, 2) = -2
        hessian(2, 4, 2) = -2
        hessian(4, 2, 2) = -2
    end subroutine double_constraint_hessian

    !> H = p^T M^-1 p / 2 + U(q) with M = diag(mass): true, and the masses.
    logical function double_mass(self, mass) result(declared)
        class(declared_double_pendulum_t), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass = 1
        declared = .true.
    end function double_mass

    !> The entries of Phi that may be nonzero: (constraint, coordinate) pairs.
    subroutine double_pattern(self, rows, columns)
        class(declared_double_pendulum_t), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        rows = [1, 1, 2, 2, 2, 2]
        columns = [1, 2, 1, 2, 3, 4]
    end subroutine double_pattern

    !> Phi at the pattern of `double_pattern`, in its order.
    subroutine double_values(self, q, rows, columns, values)
        class(declared_double_pendulum_t), intent(in) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(out) :: values(:)
        values = [2 * q(1), 2 * q(2), -2 * (q(3) - q(1)), -2 * (q(4) - q(2)), &
                  2 * (q(3) - q(1)), 2 * (q(4) - q(2))]
    end subroutine double_values

    !> The pairs (i, k) with d2U/dq_i dq_k possibly nonzero: none, U is linear.
    subroutine double_potential_pattern(self, rows, columns)
        class(declared_double_pendulum_t), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        allocate (rows(0), columns(0))
    end subroutine double_potential_pattern

    !> dH/dq in real64 arithmetic.
    subroutine double_dh_dq_double(self, q, p, gradient)
        class(declared_double_pendulum_t), intent(in) :: self
        real(dp), intent(in) :: q(:), p(:)
        real(dp), intent(out) :: gradient(:)
        gradient = [0.0_dp, real(self%gravity, dp), 0.0_dp, real(self%gravity, dp)]
    end subroutine double_dh_dq_double

end module declared_double_pendulum

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (declared_double_pendulum) declared_double_pendulum_example
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule declared_double_pendulum_example
