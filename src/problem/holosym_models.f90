!> category: internal module (use holosym)
!! The paper's example systems (docs/method.md, section 6) and the planar pendulum, each
!! defined by H, its gradients, phi and Phi, and the exact second derivatives of H and
!! phi (which an integrator may ignore and difference instead: `hessians = 'differences'`).
module holosym_models
    use holosym_kinds, only: wp, dp
    use holosym_problem, only: constrained_hamiltonian
    implicit none
    private

    public :: spherical_pendulum, spring_linkage, planar_pendulum

    !> Example 1: spherical pendulum in a nonlinear potential, q = (x, y, z):
    !! H = |p|^2/(2 mass) - mass sin(z),  phi = x^2 + y^2 + z^2 - length^2.
    type, extends(constrained_hamiltonian) :: spherical_pendulum
        real(wp) :: mass = 1    !! bob mass [kg]
        real(wp) :: length = 1  !! rod length [m]
    contains
        procedure :: hamiltonian => sphere_hamiltonian
        procedure :: dh_dq => sphere_dh_dq
        procedure :: dh_dp => sphere_dh_dp
        procedure :: constraint => sphere_constraint
        procedure :: constraint_jacobian => sphere_constraint_jacobian
        !> Exact second derivatives of H.
        procedure :: hessian => sphere_hessian
        !> Exact second derivatives of phi.
        procedure :: constraint_hessian => sphere_constraint_hessian
        !> H = p^T M^-1 p / 2 + U(q) with constant diagonal M: declared.
        procedure :: diagonal_mass => sphere_diagonal_mass
        !> dH/dq in real64 arithmetic (the cos of the real64 iterations).
        procedure :: dh_dq_double => sphere_dh_dq_double
        !> The paper's initial state q = (0, sqrt2/2, sqrt2/2), p = (0.6, 0, 0).
        procedure, nopass :: initial_state => sphere_initial_state
    end type spherical_pendulum

    interface spherical_pendulum
        module procedure new_spherical_pendulum
    end interface spherical_pendulum

    !> Example 2: spring-linkage mechanism, q = (x1, y1, x2, y2, s1, s2): two balls in
    !! circular tracks carried by two springs, the balls joined by a rod.
    type, extends(constrained_hamiltonian) :: spring_linkage
        real(wp) :: ball_mass = 1        !! m [kg]
        real(wp) :: track_mass = 1       !! m_r [kg]
        real(wp) :: stiffness = 1        !! k [N/m]
        real(wp) :: half_distance = 1    !! D [m]: fixed spring ends at -D and +D
        real(wp) :: natural_length = 0.4_wp  !! l0 [m]
        real(wp) :: track_radius = 0.2_wp    !! R [m]
        real(wp) :: rod_length = 0.8_wp      !! L [m]
    contains
        procedure :: hamiltonian => linkage_hamiltonian
        procedure :: dh_dq => linkage_dh_dq
        procedure :: dh_dp => linkage_dh_dp
        procedure :: constraint => linkage_constraint
        procedure :: constraint_jacobian => linkage_constraint_jacobian
        !> Exact second derivatives of H.
        procedure :: hessian => linkage_hessian
        !> Exact second derivatives of phi.
        procedure :: constraint_hessian => linkage_constraint_hessian
        !> H = p^T M^-1 p / 2 + U(q) with constant diagonal M: declared.
        procedure :: diagonal_mass => linkage_diagonal_mass
        !> The paper's initial state q = (-0.1, 0, 0.7, 0, -0.3, 0.5), p = (0, .05, 0, -.05, 0, 0).
        procedure, nopass :: initial_state => linkage_initial_state
    end type spring_linkage

    interface spring_linkage
        module procedure new_spring_linkage
    end interface spring_linkage

    !> Planar pendulum in Cartesian coordinates: H = |p|^2/2 + q_2, phi = |q|^2 - 1.
    type, extends(constrained_hamiltonian) :: planar_pendulum
    contains
        procedure :: hamiltonian => planar_hamiltonian
        procedure :: dh_dq => planar_dh_dq
        procedure :: dh_dp => planar_dh_dp
        procedure :: constraint => planar_constraint
        procedure :: constraint_jacobian => planar_constraint_jacobian
        !> Exact second derivatives of H.
        procedure :: hessian => planar_hessian
        !> Exact second derivatives of phi.
        procedure :: constraint_hessian => planar_constraint_hessian
        !> H = p^T M^-1 p / 2 + U(q) with constant diagonal M: declared.
        procedure :: diagonal_mass => planar_diagonal_mass
        !> q = (sin 1, -cos 1), p = 0.
        procedure, nopass :: initial_state => planar_initial_state
    end type planar_pendulum

    interface planar_pendulum
        module procedure new_planar_pendulum
    end interface planar_pendulum

contains

    ! ---------------------------------------------------------------- spherical pendulum

    !> A spherical pendulum (n = 3, m = 1) with the given mass and length (default 1, 1).
    pure function new_spherical_pendulum(mass, length) result(sys)
        real(wp), intent(in), optional :: mass   !! bob mass
        real(wp), intent(in), optional :: length !! rod length
        type(spherical_pendulum) :: sys
        sys%n = 3
        sys%m = 1
        if (present(mass)) sys%mass = mass
        if (present(length)) sys%length = length
    end function new_spherical_pendulum

    function sphere_hamiltonian(self, q, p) result(energy)
        class(spherical_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = sum(p**2) / (2 * self%mass) - self%mass * sin(q(3))
    end function sphere_hamiltonian

    subroutine sphere_dh_dq(self, q, p, gradient)
        class(spherical_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient(1:2) = 0
        gradient(3) = -self%mass * cos(q(3))
    end subroutine sphere_dh_dq

    subroutine sphere_dh_dq_double(self, q, p, gradient)
        class(spherical_pendulum), intent(in) :: self
        real(dp), intent(in) :: q(:), p(:)
        real(dp), intent(out) :: gradient(:)
        gradient(1:2) = 0
        gradient(3) = -real(self%mass, dp) * cos(q(3))
    end subroutine sphere_dh_dq_double

    subroutine sphere_dh_dp(self, q, p, gradient)
        class(spherical_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = p / self%mass
    end subroutine sphere_dh_dp

    logical function sphere_diagonal_mass(self, mass) result(declared)
        class(spherical_pendulum), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass = self%mass
        declared = .true.
    end function sphere_diagonal_mass

    subroutine sphere_constraint(self, q, phi)
        class(spherical_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi(1) = sum(q**2) - self%length**2
    end subroutine sphere_constraint

    subroutine sphere_constraint_jacobian(self, q, jacobian)
        class(spherical_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian(1, :) = 2 * q
    end subroutine sphere_constraint_jacobian

    subroutine sphere_hessian(self, q, p, hqq, hqp, hpp)
        class(spherical_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        integer :: i
        hqq = 0
        hqq(3, 3) = self%mass * sin(q(3))
        hqp = 0
        hpp = 0
        do i = 1, 3
            hpp(i, i) = 1 / self%mass
        end do
    end subroutine sphere_hessian

    subroutine sphere_constraint_hessian(self, q, hessian)
        class(spherical_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        integer :: i
        hessian = 0
        do i = 1, 3
            hessian(i, i, 1) = 2
        end do
    end subroutine sphere_constraint_hessian

    pure subroutine sphere_initial_state(q, p)
        real(wp), intent(out) :: q(:) !! (0, sqrt(2)/2, sqrt(2)/2)
        real(wp), intent(out) :: p(:) !! (0.6, 0, 0)
        q = [0.0_wp, sqrt(2.0_wp) / 2, sqrt(2.0_wp) / 2]
        p = [0.6_wp, 0.0_wp, 0.0_wp]
    end subroutine sphere_initial_state

    ! ---------------------------------------------------------------- spring-linkage

    !> The spring-linkage mechanism (n = 6, m = 3) with the paper's geometry; mass and
    !! stiffness may be given (defaults m = m_r = 1 kg, k = 1 N/m).
    pure function new_spring_linkage(stiffness, ball_mass, track_mass) result(sys)
        real(wp), intent(in), optional :: stiffness  !! spring stiffness k
        real(wp), intent(in), optional :: ball_mass  !! ball mass m
        real(wp), intent(in), optional :: track_mass !! track mass m_r
        type(spring_linkage) :: sys
        sys%n = 6
        sys%m = 3
        if (present(stiffness)) sys%stiffness = stiffness
        if (present(ball_mass)) sys%ball_mass = ball_mass
        if (present(track_mass)) sys%track_mass = track_mass
    end function new_spring_linkage

    function linkage_hamiltonian(self, q, p) result(energy)
        class(spring_linkage), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = sum(p(1:4)**2) / (2 * self%ball_mass) + sum(p(5:6)**2) / (2 * self%track_mass) &
            + self%stiffness / 2 * ((q(5) + self%half_distance - self%natural_length)**2 &
                                  + (self%half_distance - q(6) - self%natural_length)**2)
    end function linkage_hamiltonian

    subroutine linkage_dh_dq(self, q, p, gradient)
        class(spring_linkage), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient(1:4) = 0
        gradient(5) = self%stiffness * (q(5) + self%half_distance - self%natural_length)
        gradient(6) = -self%stiffness * (self%half_distance - q(6) - self%natural_length)
    end subroutine linkage_dh_dq

    subroutine linkage_dh_dp(self, q, p, gradient)
        class(spring_linkage), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient(1:4) = p(1:4) / self%ball_mass
        gradient(5:6) = p(5:6) / self%track_mass
    end subroutine linkage_dh_dp

    logical function linkage_diagonal_mass(self, mass) result(declared)
        class(spring_linkage), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass(1:4) = self%ball_mass
        mass(5:6) = self%track_mass
        declared = .true.
    end function linkage_diagonal_mass

    subroutine linkage_constraint(self, q, phi)
        class(spring_linkage), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi(1) = (q(1) - q(5))**2 + q(2)**2 - self%track_radius**2
        phi(2) = (q(3) - q(6))**2 + q(4)**2 - self%track_radius**2
        phi(3) = (q(3) - q(1))**2 + (q(4) - q(2))**2 - self%rod_length**2
    end subroutine linkage_constraint

    subroutine linkage_constraint_jacobian(self, q, jacobian)
        class(spring_linkage), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian = 0
        jacobian(1, 1) = 2 * (q(1) - q(5))
        jacobian(1, 2) = 2 * q(2)
        jacobian(1, 5) = -2 * (q(1) - q(5))
        jacobian(2, 3) = 2 * (q(3) - q(6))
        jacobian(2, 4) = 2 * q(4)
        jacobian(2, 6) = -2 * (q(3) - q(6))
        jacobian(3, 1) = -2 * (q(3) - q(1))
        jacobian(3, 2) = -2 * (q(4) - q(2))
        jacobian(3, 3) = 2 * (q(3) - q(1))
        jacobian(3, 4) = 2 * (q(4) - q(2))
    end subroutine linkage_constraint_jacobian

    subroutine linkage_hessian(self, q, p, hqq, hqp, hpp)
        class(spring_linkage), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        integer :: i
        hqq = 0
        hqq(5, 5) = self%stiffness
        hqq(6, 6) = self%stiffness
        hqp = 0
        hpp = 0
        do i = 1, 4
            hpp(i, i) = 1 / self%ball_mass
        end do
        hpp(5, 5) = 1 / self%track_mass
        hpp(6, 6) = 1 / self%track_mass
    end subroutine linkage_hessian

    subroutine linkage_constraint_hessian(self, q, hessian)
        class(spring_linkage), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        hessian = 0
        ! phi1 = (x1 - s1)^2 + y1^2: coordinates 1, 2, 5.
        call difference_square(hessian(:, :, 1), 1, 5)
        hessian(2, 2, 1) = 2
        ! phi2 = (x2 - s2)^2 + y2^2: coordinates 3, 4, 6.
        call difference_square(hessian(:, :, 2), 3, 6)
        hessian(4, 4, 2) = 2
        ! phi3 = (x2 - x1)^2 + (y2 - y1)^2.
        call difference_square(hessian(:, :, 3), 1, 3)
        call difference_square(hessian(:, :, 3), 2, 4)
    contains
        !> Add the Hessian of (q_i - q_k)^2.
        pure subroutine difference_square(block, i, k)
            real(wp), intent(inout) :: block(:, :)
            integer, intent(in) :: i, k
            block(i, i) = block(i, i) + 2
            block(k, k) = block(k, k) + 2
            block(i, k) = block(i, k) - 2
            block(k, i) = block(k, i) - 2
        end subroutine difference_square
    end subroutine linkage_constraint_hessian

    pure subroutine linkage_initial_state(q, p)
        real(wp), intent(out) :: q(:) !! (-0.1, 0, 0.7, 0, -0.3, 0.5)
        real(wp), intent(out) :: p(:) !! (0, 0.05, 0, -0.05, 0, 0)
        q = [-0.1_wp, 0.0_wp, 0.7_wp, 0.0_wp, -0.3_wp, 0.5_wp]
        p = [0.0_wp, 0.05_wp, 0.0_wp, -0.05_wp, 0.0_wp, 0.0_wp]
    end subroutine linkage_initial_state

    ! ---------------------------------------------------------------- planar pendulum

    !> The planar pendulum (n = 2, m = 1).
    pure function new_planar_pendulum() result(sys)
        type(planar_pendulum) :: sys
        sys%n = 2
        sys%m = 1
    end function new_planar_pendulum

    function planar_hamiltonian(self, q, p) result(energy)
        class(planar_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        energy = sum(p**2) / 2 + q(2)
    end function planar_hamiltonian

    subroutine planar_dh_dq(self, q, p, gradient)
        class(planar_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient(1) = 0
        gradient(2) = 1
    end subroutine planar_dh_dq

    subroutine planar_dh_dp(self, q, p, gradient)
        class(planar_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        gradient = p
    end subroutine planar_dh_dp

    subroutine planar_constraint(self, q, phi)
        class(planar_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        phi(1) = sum(q**2) - 1
    end subroutine planar_constraint

    subroutine planar_constraint_jacobian(self, q, jacobian)
        class(planar_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        jacobian(1, :) = 2 * q
    end subroutine planar_constraint_jacobian

    subroutine planar_hessian(self, q, p, hqq, hqp, hpp)
        class(planar_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        hqq = 0
        hqp = 0
        hpp = 0
        hpp(1, 1) = 1
        hpp(2, 2) = 1
    end subroutine planar_hessian

    subroutine planar_constraint_hessian(self, q, hessian)
        class(planar_pendulum), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        hessian = 0
        hessian(1, 1, 1) = 2
        hessian(2, 2, 1) = 2
    end subroutine planar_constraint_hessian

    logical function planar_diagonal_mass(self, mass) result(declared)
        class(planar_pendulum), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        mass = 1
        declared = .true.
    end function planar_diagonal_mass

    pure subroutine planar_initial_state(q, p)
        real(wp), intent(out) :: q(:) !! (sin 1, -cos 1)
        real(wp), intent(out) :: p(:) !! (0, 0)
        q = [sin(1.0_wp), -cos(1.0_wp)]
        p = 0
    end subroutine planar_initial_state

end module holosym_models
