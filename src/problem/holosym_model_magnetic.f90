!> category: internal module (use holosym)
!! A charged particle on a sphere in a uniform magnetic field and gravity: a Hamiltonian
!! that is not separable (dH/dp depends on q).
!!
!! With the vector potential A(q) = (B/2) (-y, x, 0) of the field B e_z (B is charge times
!! field strength) and q = (x, y, z) on the sphere |q| = R:
!!     H = |p - A(q)|^2 / (2 mass) + mass g z,     phi = x^2 + y^2 + z^2 - R^2.
!! The canonical momentum p is not mass times velocity: dH/dp = (p - A(q))/mass, so the
!! hidden constraint reads q . (p - A(q)) = 0, i.e. q . p = 0 since q . A(q) = 0.
!! The z component of the canonical angular momentum, x p_y - y p_x, is conserved.
!!
!! What the model declares: exact second derivatives of H (including the mixed block
!! d2H/dq dp, which a separable H does not have) and of phi. It declares no diagonal mass
!! matrix (H is not p^T M^-1 p / 2 + U(q)), so the integrator takes its general step.
module holosym_model_magnetic
    use holosym_kinds, only: wp
    use holosym_problem, only: constrained_hamiltonian
    implicit none
    private

    public :: magnetic_sphere

    !> A charged particle on a sphere in a magnetic field (n = 3, m = 1).
    type, extends(constrained_hamiltonian) :: magnetic_sphere
        real(wp) :: mass = 1    !! particle mass [kg]
        real(wp) :: field = 2   !! B: charge times field strength along z [kg/s]
        real(wp) :: gravity = 1 !! g [m/s^2], along -z
        real(wp) :: radius = 1  !! R [m]
    contains
        procedure :: hamiltonian => magnetic_hamiltonian
        procedure :: dh_dq => magnetic_dh_dq
        procedure :: dh_dp => magnetic_dh_dp
        procedure :: constraint => magnetic_constraint
        procedure :: constraint_jacobian => magnetic_constraint_jacobian
        !> Exact second derivatives of H.
        procedure :: hessian => magnetic_hessian
        !> Exact second derivatives of phi.
        procedure :: constraint_hessian => magnetic_constraint_hessian
        !> The vector potential A(q).
        procedure :: vector_potential => magnetic_vector_potential
        !> A start on the manifold from a position and a tangent velocity.
        procedure :: initial_state => magnetic_initial_state
    end type magnetic_sphere

    interface magnetic_sphere
        module procedure new_magnetic_sphere
    end interface magnetic_sphere

contains

    !> The particle on a sphere; defaults mass 1 kg, B = 2 kg/s, g = 1 m/s^2, R = 1 m.
    pure function new_magnetic_sphere(mass, field, gravity, radius) result(sys)
        real(wp), intent(in), optional :: mass    !! particle mass
        real(wp), intent(in), optional :: field   !! B (charge times field)
        real(wp), intent(in), optional :: gravity !! g
        real(wp), intent(in), optional :: radius  !! R
        type(magnetic_sphere) :: sys
        sys%n = 3
        sys%m = 1
        if (present(mass)) sys%mass = mass
        if (present(field)) sys%field = field
        if (present(gravity)) sys%gravity = gravity
        if (present(radius)) sys%radius = radius
    end function new_magnetic_sphere

    !> A(q) = (B/2) (-y, x, 0).
    pure function magnetic_vector_potential(self, q) result(a)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:) !! position (3)
        real(wp) :: a(3)
        a = self%field / 2 * [-q(2), q(1), 0.0_wp]
    end function magnetic_vector_potential

    function magnetic_hamiltonian(self, q, p) result(energy)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = sum((p - self%vector_potential(q))**2) / (2 * self%mass) &
            + self%mass * self%gravity * q(3)
    end function magnetic_hamiltonian

    !> dH/dq = -(dA/dq)^T (p - A)/mass + mass g e_z.
    subroutine magnetic_dh_dq(self, q, p, gradient)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        real(wp) :: v(3)
        v = (p - self%vector_potential(q)) / self%mass
        gradient(1) = -self%field / 2 * v(2)
        gradient(2) = self%field / 2 * v(1)
        gradient(3) = self%mass * self%gravity
    end subroutine magnetic_dh_dq

    subroutine magnetic_dh_dp(self, q, p, gradient)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = (p - self%vector_potential(q)) / self%mass
    end subroutine magnetic_dh_dp

    subroutine magnetic_constraint(self, q, phi)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi(1) = sum(q**2) - self%radius**2
    end subroutine magnetic_constraint

    subroutine magnetic_constraint_jacobian(self, q, jacobian)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian(1, :) = 2 * q
    end subroutine magnetic_constraint_jacobian

    subroutine magnetic_hessian(self, q, p, hqq, hqp, hpp)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        real(wp) :: half
        integer :: i
        half = self%field / 2
        hqq = 0
        hqq(1, 1) = half**2 / self%mass
        hqq(2, 2) = half**2 / self%mass
        hqp = 0
        hqp(1, 2) = -half / self%mass
        hqp(2, 1) = half / self%mass
        hpp = 0
        do i = 1, 3
            hpp(i, i) = 1 / self%mass
        end do
    end subroutine magnetic_hessian

    subroutine magnetic_constraint_hessian(self, q, hessian)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        integer :: i
        hessian = 0
        do i = 1, 3
            hessian(i, i, 1) = 2
        end do
    end subroutine magnetic_constraint_hessian

    !> A state on the manifold: q = R u for the unit vector u (default (3/5, 0, -4/5)) and
    !! the velocity v = omega x q (default omega = (0.2, 1.0, -0.3) rad/s), tangent to the
    !! sphere; p = mass v + A(q).
    pure subroutine magnetic_initial_state(self, q, p, direction, omega)
        class(magnetic_sphere), intent(in) :: self
        real(wp), intent(out) :: q(:) !! position (3)
        real(wp), intent(out) :: p(:) !! canonical momentum (3)
        real(wp), intent(in), optional :: direction(3) !! unit vector u
        real(wp), intent(in), optional :: omega(3)     !! angular velocity [rad/s]
        real(wp) :: u(3), w(3), v(3)
        u = [3.0_wp / 5, 0.0_wp, -4.0_wp / 5]
        if (present(direction)) u = direction
        w = [0.2_wp, 1.0_wp, -0.3_wp]
        if (present(omega)) w = omega
        q = self%radius * u
        v = [w(2) * q(3) - w(3) * q(2), w(3) * q(1) - w(1) * q(3), w(1) * q(2) - w(2) * q(1)]
        p = self%mass * v + self%vector_potential(q)
    end subroutine magnetic_initial_state

end module holosym_model_magnetic
