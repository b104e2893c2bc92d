!> category: internal module (use holosym)
!! Two bodies on a sphere joined by a rod: a dumbbell sliding on a sphere in gravity.
!!
!! Point masses m_1, m_2 at r_1, r_2 in R^3, both on the sphere |r| = R about the origin and
!! a rod of length L between them; uniform gravity g along -z.
!!     q = (x_1, y_1, z_1, x_2, y_2, z_2),   H = |p_1|^2/(2 m_1) + |p_2|^2/(2 m_2)
!!                                                 + g (m_1 z_1 + m_2 z_2),
!!     phi_1 = |r_1|^2 - R^2,   phi_2 = |r_2|^2 - R^2,   phi_3 = |r_1 - r_2|^2 - L^2.
!! The three constraints make the pair and the centre a rigid triangle turning about the
!! centre: a heavy rigid body with a fixed point (n = 6, m = 3, three degrees of freedom),
!! whose motion is not integrable for a generic start.
!!
!! What the model declares, so that the integrator takes its reduced step with sparse
!! linear algebra: a constant diagonal mass matrix, the nonzero pattern of Phi (phi_1 and
!! phi_2 involve one body each, phi_3 both) with its values, a potential linear in q (no
!! second derivatives), and exact second derivatives of H and phi.
module holosym_model_dumbbell
    use holosym_kinds, only: wp
    use holosym_problem, only: constrained_hamiltonian
    implicit none
    private

    public :: sphere_dumbbell

    !> Two bodies on a sphere with a rod between them (n = 6, m = 3).
    type, extends(constrained_hamiltonian) :: sphere_dumbbell
        real(wp) :: masses(2) = [1.0_wp, 2.0_wp] !! m_1, m_2 [kg]
        real(wp) :: radius = 1       !! R [m], radius of the sphere
        real(wp) :: rod_length = 1   !! L [m], 0 < L < 2R
        real(wp) :: gravity = 1      !! g [m/s^2], along -z
    contains
        procedure :: hamiltonian => dumbbell_hamiltonian
        procedure :: dh_dq => dumbbell_dh_dq
        procedure :: dh_dp => dumbbell_dh_dp
        procedure :: constraint => dumbbell_constraint
        procedure :: constraint_jacobian => dumbbell_constraint_jacobian
        !> Exact second derivatives of H (all zero but d2H/dp2 = M^-1).
        procedure :: hessian => dumbbell_hessian
        !> Exact second derivatives of phi.
        procedure :: constraint_hessian => dumbbell_constraint_hessian
        !> Declared: H = p^T M^-1 p / 2 + U(q), M = diag(m_1, m_1, m_1, m_2, m_2, m_2).
        procedure :: diagonal_mass => dumbbell_diagonal_mass
        !> Declared: the 12 nonzero entries of Phi.
        procedure :: constraint_sparsity => dumbbell_constraint_sparsity
        !> Values of Phi at the declared pattern.
        procedure :: constraint_jacobian_values => dumbbell_constraint_values
        !> Declared: U linear in q.
        procedure :: potential_sparsity => dumbbell_potential_sparsity
        !> A start on the manifold: the rigid triangle turning with a given angular velocity.
        procedure :: initial_state => dumbbell_initial_state
    end type sphere_dumbbell

    interface sphere_dumbbell
        module procedure new_sphere_dumbbell
    end interface sphere_dumbbell

contains

    !> The dumbbell on a sphere; defaults m = (1, 2) kg, R = 1 m, L = 1 m, g = 1 m/s^2.
    pure function new_sphere_dumbbell(masses, radius, rod_length, gravity) result(sys)
        real(wp), intent(in), optional :: masses(2)  !! m_1, m_2
        real(wp), intent(in), optional :: radius     !! R
        real(wp), intent(in), optional :: rod_length !! L
        real(wp), intent(in), optional :: gravity    !! g
        type(sphere_dumbbell) :: sys
        sys%n = 6
        sys%m = 3
        if (present(masses)) sys%masses = masses
        if (present(radius)) sys%radius = radius
        if (present(rod_length)) sys%rod_length = rod_length
        if (present(gravity)) sys%gravity = gravity
    end function new_sphere_dumbbell

    function dumbbell_hamiltonian(self, q, p) result(energy)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = sum(p(1:3)**2) / (2 * self%masses(1)) + sum(p(4:6)**2) / (2 * self%masses(2)) &
            + self%gravity * (self%masses(1) * q(3) + self%masses(2) * q(6))
    end function dumbbell_hamiltonian

    subroutine dumbbell_dh_dq(self, q, p, gradient)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = 0
        gradient(3) = self%gravity * self%masses(1)
        gradient(6) = self%gravity * self%masses(2)
    end subroutine dumbbell_dh_dq

    subroutine dumbbell_dh_dp(self, q, p, gradient)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient(1:3) = p(1:3) / self%masses(1)
        gradient(4:6) = p(4:6) / self%masses(2)
    end subroutine dumbbell_dh_dp

    subroutine dumbbell_constraint(self, q, phi)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi(1) = sum(q(1:3)**2) - self%radius**2
        phi(2) = sum(q(4:6)**2) - self%radius**2
        phi(3) = sum((q(1:3) - q(4:6))**2) - self%rod_length**2
    end subroutine dumbbell_constraint

    subroutine dumbbell_constraint_jacobian(self, q, jacobian)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian = 0
        jacobian(1, 1:3) = 2 * q(1:3)
        jacobian(2, 4:6) = 2 * q(4:6)
        jacobian(3, 1:3) = 2 * (q(1:3) - q(4:6))
        jacobian(3, 4:6) = -2 * (q(1:3) - q(4:6))
    end subroutine dumbbell_constraint_jacobian

    subroutine dumbbell_hessian(self, q, p, hqq, hqp, hpp)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        integer :: i
        hqq = 0
        hqp = 0
        hpp = 0
        do i = 1, 6
            hpp(i, i) = 1 / self%masses((i + 2) / 3)
        end do
    end subroutine dumbbell_hessian

    subroutine dumbbell_constraint_hessian(self, q, hessian)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        integer :: i
        hessian = 0
        do i = 1, 3
            hessian(i, i, 1) = 2
            hessian(i + 3, i + 3, 2) = 2
            hessian(i, i, 3) = 2
            hessian(i + 3, i + 3, 3) = 2
            hessian(i, i + 3, 3) = -2
            hessian(i + 3, i, 3) = -2
        end do
    end subroutine dumbbell_constraint_hessian

    logical function dumbbell_diagonal_mass(self, mass) result(declared)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass(1:3) = self%masses(1)
        mass(4:6) = self%masses(2)
        declared = .true.
    end function dumbbell_diagonal_mass

    !> phi_1: coordinates 1..3; phi_2: 4..6; phi_3: 1..6.
    subroutine dumbbell_constraint_sparsity(self, rows, columns)
        class(sphere_dumbbell), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        rows = [1, 1, 1, 2, 2, 2, 3, 3, 3, 3, 3, 3]
        columns = [1, 2, 3, 4, 5, 6, 1, 2, 3, 4, 5, 6]
    end subroutine dumbbell_constraint_sparsity

    !> The values of Phi in the order of `dumbbell_constraint_sparsity`.
    subroutine dumbbell_constraint_values(self, q, rows, columns, values)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(out) :: values(:)
        values(1:3) = 2 * q(1:3)
        values(4:6) = 2 * q(4:6)
        values(7:9) = 2 * (q(1:3) - q(4:6))
        values(10:12) = -2 * (q(1:3) - q(4:6))
    end subroutine dumbbell_constraint_values

    !> U = g (m_1 z_1 + m_2 z_2) is linear: no second derivatives.
    subroutine dumbbell_potential_sparsity(self, rows, columns)
        class(sphere_dumbbell), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        allocate (rows(0), columns(0))
    end subroutine dumbbell_potential_sparsity

    !> A state on the manifold. The rod's midpoint direction is u = (sin tilt, 0, -cos tilt)
    !! (default tilt 0.6435 rad, u = (3/5, 0, -4/5)); the bodies sit at
    !! r = R (cos a u +- sin a e) with e = (0, 1, 0) and sin a = L/(2R); the velocities of a
    !! rigid rotation with angular velocity omega, v_k = omega x r_k (default
    !! omega = (0.3, -0.5, 0.8) rad/s), satisfy both constraint levels exactly.
    pure subroutine dumbbell_initial_state(self, q, p, tilt, omega)
        class(sphere_dumbbell), intent(in) :: self
        real(wp), intent(out) :: q(:) !! coordinates (6)
        real(wp), intent(out) :: p(:) !! momenta (6)
        real(wp), intent(in), optional :: tilt     !! angle of u from the downward vertical
        real(wp), intent(in), optional :: omega(3) !! angular velocity [rad/s]
        real(wp) :: u(3), e(3), w(3), half_sin, half_cos
        u = [3.0_wp / 5, 0.0_wp, -4.0_wp / 5]
        if (present(tilt)) u = [sin(tilt), 0.0_wp, -cos(tilt)]
        w = [0.3_wp, -0.5_wp, 0.8_wp]
        if (present(omega)) w = omega
        e = [0.0_wp, 1.0_wp, 0.0_wp]
        half_sin = self%rod_length / (2 * self%radius)
        half_cos = sqrt((1 - half_sin) * (1 + half_sin))
        q(1:3) = self%radius * (half_cos * u + half_sin * e)
        q(4:6) = self%radius * (half_cos * u - half_sin * e)
        p(1:3) = self%masses(1) * cross(w, q(1:3))
        p(4:6) = self%masses(2) * cross(w, q(4:6))
    contains
        pure function cross(a, b) result(c)
            real(wp), intent(in) :: a(3), b(3)
            real(wp) :: c(3)
            c = [a(2) * b(3) - a(3) * b(2), a(3) * b(1) - a(1) * b(3), a(1) * b(2) - a(2) * b(1)]
        end function cross
    end subroutine dumbbell_initial_state

end module holosym_model_dumbbell
