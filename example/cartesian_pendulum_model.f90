!> A system defined by the user: a planar pendulum in Cartesian coordinates q = (x, y),
!! H = |p|^2/(2 mass) + mass gravity y, one constraint phi = x^2 + y^2 - length^2.
!! Only H, dH/dq, dH/dp, phi and Phi = dphi/dq are written; the second derivatives Newton
!! needs come from holosym's default finite differences. The parameters are components.
!!
!! The module also holds an observer that tracks the energy error and stops the run
!! whenever the bob crosses x = 0, so that the crossing can be located with dense output.
module cartesian_pendulum_model
    use holosym, only: wp, constrained_hamiltonian, step_observer, step_info_t
    implicit none
    private

    public :: cartesian_pendulum, crossing_monitor

    !> Planar pendulum, q = (x, y): a bob of `mass` on a rod of `length` under `gravity`.
    type, extends(constrained_hamiltonian) :: cartesian_pendulum
        real(wp) :: mass = 1     !! bob mass
        real(wp) :: length = 1   !! rod length
        real(wp) :: gravity = 1  !! gravitational acceleration
    contains
        procedure :: hamiltonian => pendulum_hamiltonian
        procedure :: dh_dq => pendulum_dh_dq
        procedure :: dh_dp => pendulum_dh_dp
        procedure :: constraint => pendulum_constraint
        procedure :: constraint_jacobian => pendulum_constraint_jacobian
    end type cartesian_pendulum

    !> The constructor sets the sizes n = 2, m = 1 (and optionally the length).
    interface cartesian_pendulum
        module procedure new_cartesian_pendulum
    end interface cartesian_pendulum

    !> Observer: max |(H - H0)/H0| and max |phi| over the steps; halts after a step in
    !! which x changed sign.
    type, extends(step_observer) :: crossing_monitor
        type(cartesian_pendulum) :: sys        !! the system, to evaluate H
        real(wp) :: energy0 = 0                !! H of the initial state
        real(wp) :: previous_x = 0             !! x at the start of the next step
        real(wp) :: max_energy_error = 0       !! largest relative energy error so far
        real(wp) :: max_constraint = 0         !! largest |phi| at the nodes so far
    contains
        procedure :: observe => crossing_observe
    end type crossing_monitor

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! example's module out of `fpm install` of holosym (not needed in your code).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> A pendulum of the given length (default 1); n = 2 coordinates, m = 1 constraint.
    pure function new_cartesian_pendulum(length) result(sys)
        real(wp), intent(in), optional :: length !! rod length
        type(cartesian_pendulum) :: sys
        sys%n = 2
        sys%m = 1
        if (present(length)) sys%length = length
    end function new_cartesian_pendulum

    !> H = |p|^2/(2 mass) + mass gravity y.
    function pendulum_hamiltonian(self, q, p) result(energy)
        class(cartesian_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:) !! (x, y)
        real(wp), intent(in) :: p(:) !! (p_x, p_y)
        real(wp) :: energy
        energy = sum(p**2) / (2 * self%mass) + self%mass * self%gravity * q(2)
    end function pendulum_hamiltonian

    !> dH/dq = (0, mass gravity).
    subroutine pendulum_dh_dq(self, q, p, gradient)
        class(cartesian_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)          !! (x, y)
        real(wp), intent(in) :: p(:)          !! (p_x, p_y)
        real(wp), intent(out) :: gradient(:)  !! dH/dq
        gradient(1) = 0
        gradient(2) = self%mass * self%gravity
    end subroutine pendulum_dh_dq

    !> dH/dp = p / mass.
    subroutine pendulum_dh_dp(self, q, p, gradient)
        class(cartesian_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)          !! (x, y)
        real(wp), intent(in) :: p(:)          !! (p_x, p_y)
        real(wp), intent(out) :: gradient(:)  !! dH/dp
        gradient = p / self%mass
    end subroutine pendulum_dh_dp

    !> phi = x^2 + y^2 - length^2.
    subroutine pendulum_constraint(self, q, phi)
        class(cartesian_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)     !! (x, y)
        real(wp), intent(out) :: phi(:)  !! phi(1)
        phi(1) = sum(q**2) - self%length**2
    end subroutine pendulum_constraint

    !> Phi = (2x, 2y).
    subroutine pendulum_constraint_jacobian(self, q, jacobian)
        class(cartesian_pendulum), intent(in) :: self !! the system
        real(wp), intent(in) :: q(:)              !! (x, y)
        real(wp), intent(out) :: jacobian(:, :)   !! 1 x 2
        jacobian(1, :) = 2 * q
    end subroutine pendulum_constraint_jacobian

    !> Track the maxima; halt when x changed sign during the step.
    subroutine crossing_observe(self, step, t, q, p, info, halt)
        class(crossing_monitor), intent(inout) :: self !! the monitor
        integer, intent(in) :: step          !! step number within this `integrate` call
        real(wp), intent(in) :: t            !! time since the start of this call
        real(wp), intent(in) :: q(:)         !! coordinates after the step
        real(wp), intent(in) :: p(:)         !! momenta after the step
        type(step_info_t), intent(in) :: info !! diagnostics of the step
        logical, intent(inout) :: halt       !! set after a sign change of x
        self%max_energy_error = max(self%max_energy_error, &
            abs((self%sys%hamiltonian(q, p) - self%energy0) / self%energy0))
        self%max_constraint = max(self%max_constraint, info%constraint_residual)
        halt = (q(1) < 0) .neqv. (self%previous_x < 0)
        self%previous_x = q(1)
    end subroutine crossing_observe

end module cartesian_pendulum_model

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (cartesian_pendulum_model) cartesian_pendulum_model_example
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule cartesian_pendulum_model_example
