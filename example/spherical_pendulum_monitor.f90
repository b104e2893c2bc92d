!> Monitor for the spherical-pendulum example: the largest relative energy error and the
!! largest constraint residuals over all steps of a run.
module spherical_pendulum_monitor
    use holosym, only: wp, step_observer, step_info_t, constrained_hamiltonian
    implicit none
    private

    public :: error_monitor

    !> Observer tracking max |(H - H0)/H0|, max |phi| and max |Phi H_p| over the steps.
    type, extends(step_observer) :: error_monitor
        !> The system, to evaluate H.
        class(constrained_hamiltonian), allocatable :: sys
        !> Energy of the initial state.
        real(wp) :: energy0 = 0
        !> Largest relative energy error so far.
        real(wp) :: max_energy_error = 0
        !> Largest |phi| at the displacement nodes so far.
        real(wp) :: max_constraint = 0
        !> Largest |Phi H_p| at the step ends so far.
        real(wp) :: max_velocity = 0
        !> Newton iterations over all steps.
        integer :: iterations = 0
    contains
        procedure :: observe => monitor_observe
    end type error_monitor

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! example's module out of `fpm install` of holosym (not needed in your code).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> Update the maxima after each step.
    subroutine monitor_observe(self, step, t, q, p, info, halt)
        class(error_monitor), intent(inout) :: self !! the monitor
        integer, intent(in) :: step          !! step number
        real(wp), intent(in) :: t            !! time
        real(wp), intent(in) :: q(:)         !! coordinates after the step
        real(wp), intent(in) :: p(:)         !! momenta after the step
        type(step_info_t), intent(in) :: info !! diagnostics of the step
        logical, intent(inout) :: halt       !! never set: run to the end
        self%max_energy_error = max(self%max_energy_error, &
            abs((self%sys%hamiltonian(q, p) - self%energy0) / self%energy0))
        self%max_constraint = max(self%max_constraint, info%constraint_residual)
        self%max_velocity = max(self%max_velocity, info%velocity_residual)
        self%iterations = self%iterations + info%newton_iterations
    end subroutine monitor_observe

end module spherical_pendulum_monitor

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (spherical_pendulum_monitor) spherical_pendulum_monitor_example
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule spherical_pendulum_monitor_example
