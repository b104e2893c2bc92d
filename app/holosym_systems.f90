!> The systems the `holosym` command knows by name, each with its initial state: the
!! spherical pendulum (paper Example 1), the spring-linkage mechanism (Example 2) and the
!! planar pendulum. Every command and study that takes a system name gets the model here.
module holosym_systems
    use holosym_kinds, only: wp
    use holosym_status, only: holosym_status_t, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    implicit none
    private

    public :: make_system, is_system_name

    !> The names, in the order of the help texts; the first is the default of the commands.
    character(len=*), parameter, public :: system_names(*) = [character(len=8) :: &
        "pendulum", "linkage", "planar"]
    !> The names as a message lists them.
    character(len=*), parameter, public :: system_choices = "pendulum, linkage or planar"

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
