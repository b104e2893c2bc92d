!> The systems the `holosym` command knows by name, each with its initial state: the
!! spherical pendulum (paper Example 1), the spring-linkage mechanism (Example 2), the
!! planar pendulum, and the catalogue beyond the paper: the double pendulum, two bodies
!! on a sphere joined by a rod, a charged particle on a sphere in a magnetic field and a
!! spherical pendulum in a generic potential. Every command and study that takes a system
!! name gets the model here.
module holosym_systems
    use holosym_kinds, only: wp
    use holosym_status, only: holosym_status_t, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_model_dumbbell, only: sphere_dumbbell
    use holosym_model_magnetic, only: magnetic_sphere
    use holosym_model_generic, only: generic_pendulum
    implicit none
    private

    public :: make_system, is_system_name

    !> The names, in the order of the help texts; the first is the default of the commands.
    character(len=*), parameter, public :: system_names(*) = [character(len=8) :: &
        "pendulum", "linkage", "planar", "double", "dumbbell", "magnetic", "generic"]
    !> The names as a message lists them.
    character(len=*), parameter, public :: system_choices = &
        "pendulum, linkage, planar, double, dumbbell, magnetic or generic"
    !> Link angles (from the downward vertical) and angular velocities of the double
    !! pendulum's start.
    real(wp), parameter :: double_angles(2) = [1.0_wp, 0.5_wp]
    real(wp), parameter :: double_rates(2) = [0.0_wp, 0.0_wp]

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> Whether `name` is one of `system_names`.
    pure logical function is_system_name(name)
        character(len=*), intent(in) :: name !! a system name
        is_system_name = any(system_names == name)
    end function is_system_name

    !> The system called `name` and its initial state.
    !! Fails with HOLOSYM_INVALID_ARGUMENT for an unknown name.
    subroutine make_system(name, sys, q, p, status)
        character(len=*), intent(in) :: name  !! one of `system_names`
        class(constrained_hamiltonian), allocatable, intent(out) :: sys !! the system
        real(wp), allocatable, intent(out) :: q(:) !! initial coordinates (n)
        real(wp), allocatable, intent(out) :: p(:) !! initial momenta (n)
        type(holosym_status_t), intent(out) :: status !! outcome
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        type(planar_pendulum) :: planar
        type(pendulum_chain) :: chain
        type(sphere_dumbbell) :: dumbbell
        type(magnetic_sphere) :: magnetic
        type(generic_pendulum) :: generic

        status%code = HOLOSYM_SUCCESS
        status%message = ""
        select case (name)
        case ("pendulum")
            sphere = spherical_pendulum()
            allocate (q(sphere%n), p(sphere%n))
            call sphere%initial_state(q, p)
            allocate (sys, source=sphere)
        case ("linkage")
            linkage = spring_linkage()
            allocate (q(linkage%n), p(linkage%n))
            call linkage%initial_state(q, p)
            allocate (sys, source=linkage)
        case ("planar")
            planar = planar_pendulum()
            allocate (q(planar%n), p(planar%n))
            call planar%initial_state(q, p)
            allocate (sys, source=planar)
        case ("double")
            chain = pendulum_chain(2, masses=[1.0_wp, 2.0_wp], lengths=[1.0_wp, 0.7_wp])
            allocate (q(chain%n), p(chain%n))
            call chain%state_from_angles(double_angles, double_rates, q, p)
            allocate (sys, source=chain)
        case ("dumbbell")
            dumbbell = sphere_dumbbell()
            allocate (q(dumbbell%n), p(dumbbell%n))
            call dumbbell%initial_state(q, p)
            allocate (sys, source=dumbbell)
        case ("magnetic")
            magnetic = magnetic_sphere()
            allocate (q(magnetic%n), p(magnetic%n))
            call magnetic%initial_state(q, p)
            allocate (sys, source=magnetic)
        case ("generic")
            generic = generic_pendulum()
            allocate (q(generic%n), p(generic%n))
            call generic%initial_state(q, p)
            allocate (sys, source=generic)
        case default
            status%code = HOLOSYM_INVALID_ARGUMENT
            status%message = "unknown system '" // name // "'"
        end select
    end subroutine make_system

end module holosym_systems

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_systems) holosym_systems_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_systems_app
