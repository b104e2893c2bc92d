!> category: internal module (use holosym)
!! A spherical pendulum in a generic potential, without rotational symmetry.
!!
!! q = (x, y, z) on the sphere |q| = R, mass m, and
!!     H = |p|^2/(2 m) + U(q),
!!     U = m g z + a x^2 + b x y + c y z + d sin(x + 2 y),
!!     phi = x^2 + y^2 + z^2 - R^2.
!! The paper's pendulum (U = -m sin z) is symmetric about the z axis: its Hessian is
!! degenerate along the surplus displacement modes of a scheme with M >= N + 2, whose
!! Newton Jacobian is then singular. Here no direction is special, the Jacobian of those
!! schemes is nonsingular, and the order law r = 2N for M >= N + 2 can be measured
!! (`holosym tables --system generic`).
!!
!! What the model declares: a constant diagonal mass matrix (so the integrator takes its
!! reduced step) and exact second derivatives of H and phi; the Hessian of U is dense.
module holosym_model_generic
    use holosym_kinds, only: wp
    use holosym_problem, only: constrained_hamiltonian
    implicit none
    private

    public :: generic_pendulum

    !> Spherical pendulum in the potential U above (n = 3, m = 1).
    type, extends(constrained_hamiltonian) :: generic_pendulum
        real(wp) :: mass = 1     !! m [kg]
        real(wp) :: radius = 1   !! R [m]
        real(wp) :: gravity = 1  !! g [m/s^2], along -z
        !> a, b, c, d of U [J/m^2 for a, b, c; J for d].
        real(wp) :: coefficients(4) = [0.2_wp, 0.3_wp, 0.25_wp, 0.1_wp]
    contains
        procedure :: hamiltonian => generic_hamiltonian
        procedure :: dh_dq => generic_dh_dq
        procedure :: dh_dp => generic_dh_dp
        procedure :: constraint => generic_constraint
        procedure :: constraint_jacobian => generic_constraint_jacobian
        !> Exact second derivatives of H.
        procedure :: hessian => generic_hessian
        !> Exact second derivatives of phi.
        procedure :: constraint_hessian => generic_constraint_hessian
        !> Declared: H = p^T M^-1 p / 2 + U(q) with M = m I.
        procedure :: diagonal_mass => generic_diagonal_mass
        !> The potential U(q).
        procedure :: potential => generic_potential
        !> A start on the manifold: q = R (3/5, 0, -4/5), p = m (0.4, 0.5, 0.3).
        procedure :: initial_state => generic_initial_state
    end type generic_pendulum

    interface generic_pendulum
        module procedure new_generic_pendulum
    end interface generic_pendulum

contains

    !> The pendulum; defaults m = 1 kg, R = 1 m, g = 1 m/s^2, (a, b, c, d) =
    !! (0.2, 0.3, 0.25, 0.1).
    pure function new_generic_pendulum(mass, radius, gravity, coefficients) result(sys)
        real(wp), intent(in), optional :: mass            !! m
        real(wp), intent(in), optional :: radius          !! R
        real(wp), intent(in), optional :: gravity         !! g
        real(wp), intent(in), optional :: coefficients(4) !! a, b, c, d
        type(generic_pendulum) :: sys
        sys%n = 3
        sys%m = 1
        if (present(mass)) sys%mass = mass
        if (present(radius)) sys%radius = radius
        if (present(gravity)) sys%gravity = gravity
        if (present(coefficients)) sys%coefficients = coefficients
    end function new_generic_pendulum

    !> U(q) = m g z + a x^2 + b x y + c y z + d sin(x + 2 y).
    pure real(wp) function generic_potential(self, q) result(u)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:) !! position (3)
        associate (x => q(1), y => q(2), z => q(3), k => self%coefficients)
            u = self%mass * self%gravity * z + k(1) * x**2 + k(2) * x * y + k(3) * y * z &
                + k(4) * sin(x + 2 * y)
        end associate
    end function generic_potential

    function generic_hamiltonian(self, q, p) result(energy)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = sum(p**2) / (2 * self%mass) + self%potential(q)
    end function generic_hamiltonian

    subroutine generic_dh_dq(self, q, p, gradient)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        real(wp) :: wave
        associate (x => q(1), y => q(2), z => q(3), k => self%coefficients)
            wave = k(4) * cos(x + 2 * y)
            gradient(1) = 2 * k(1) * x + k(2) * y + wave
            gradient(2) = k(2) * x + k(3) * z + 2 * wave
            gradient(3) = self%mass * self%gravity + k(3) * y
        end associate
    end subroutine generic_dh_dq

    subroutine generic_dh_dp(self, q, p, gradient)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = p / self%mass
    end subroutine generic_dh_dp

    subroutine generic_constraint(self, q, phi)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi(1) = sum(q**2) - self%radius**2
    end subroutine generic_constraint

    subroutine generic_constraint_jacobian(self, q, jacobian)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian(1, :) = 2 * q
    end subroutine generic_constraint_jacobian

    subroutine generic_hessian(self, q, p, hqq, hqp, hpp)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        real(wp) :: wave
        integer :: i
        associate (x => q(1), y => q(2), k => self%coefficients)
            wave = -k(4) * sin(x + 2 * y)
            hqq(1, :) = [2 * k(1) + wave, k(2) + 2 * wave, 0.0_wp]
            hqq(2, :) = [k(2) + 2 * wave, 4 * wave, k(3)]
            hqq(3, :) = [0.0_wp, k(3), 0.0_wp]
        end associate
        hqp = 0
        hpp = 0
        do i = 1, 3
            hpp(i, i) = 1 / self%mass
        end do
    end subroutine generic_hessian

    subroutine generic_constraint_hessian(self, q, hessian)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        integer :: i
        hessian = 0
        do i = 1, 3
            hessian(i, i, 1) = 2
        end do
    end subroutine generic_constraint_hessian

    logical function generic_diagonal_mass(self, mass) result(declared)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass = self%mass
        declared = .true.
    end function generic_diagonal_mass

    !> q = R (3/5, 0, -4/5) and p = m v with v = (0.4, 0.5, 0.3), tangent to the sphere.
    pure subroutine generic_initial_state(self, q, p)
        class(generic_pendulum), intent(in) :: self
        real(wp), intent(out) :: q(:) !! position (3)
        real(wp), intent(out) :: p(:) !! momentum (3)
        q = self%radius * [3.0_wp / 5, 0.0_wp, -4.0_wp / 5]
        p = self%mass * [0.4_wp, 0.5_wp, 0.3_wp]
    end subroutine generic_initial_state

end module holosym_model_generic
