!> The built-in systems of the tests by name, each with its documented start state: the
!! paper's spherical pendulum and spring-linkage, the planar pendulum, the double pendulum,
!! a chain of four links released from 0.5, 0.4, 0.3, 0.2 rad, the dumbbell on a sphere, the
!! charged particle in a magnetic field and the pendulum in a generic potential. (The
!! `holosym` command's own list is app/holosym_systems.f90, which tests cannot use.)
module holosym_test_systems
    use holosym_kinds, only: wp
    use holosym_problem, only: constrained_hamiltonian
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_model_dumbbell, only: sphere_dumbbell
    use holosym_model_magnetic, only: magnetic_sphere
    use holosym_model_generic, only: generic_pendulum
    implicit none
    private
    public :: builtin_system

contains

    !> The system called `name` (pendulum, linkage, planar, double, chain4, dumbbell,
    !! magnetic, generic) and its start; `sys` is not allocated for another name.
    subroutine builtin_system(name, sys, q, p)
        character(len=*), intent(in) :: name
        class(constrained_hamiltonian), allocatable, intent(out) :: sys
        real(wp), allocatable, intent(out) :: q(:), p(:)
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        type(planar_pendulum) :: planar
        type(pendulum_chain) :: chain
        type(sphere_dumbbell) :: dumbbell
        type(magnetic_sphere) :: magnetic
        type(generic_pendulum) :: generic
        select case (name)
        case ("pendulum")
            sphere = spherical_pendulum()
            allocate (q(3), p(3))
            call sphere%initial_state(q, p)
            allocate (sys, source=sphere)
        case ("linkage")
            linkage = spring_linkage()
            allocate (q(6), p(6))
            call linkage%initial_state(q, p)
            allocate (sys, source=linkage)
        case ("planar")
            planar = planar_pendulum()
            allocate (q(2), p(2))
            call planar%initial_state(q, p)
            allocate (sys, source=planar)
        case ("double")
            chain = pendulum_chain(2, masses=[1.0_wp, 2.0_wp], lengths=[1.0_wp, 0.7_wp])
            allocate (q(4), p(4))
            call chain%state_from_angles([1.0_wp, 0.5_wp], [0.0_wp, 0.0_wp], q, p)
            allocate (sys, source=chain)
        case ("chain4")
            chain = pendulum_chain(4)
            allocate (q(8), p(8))
            call chain%state_from_angles([0.5_wp, 0.4_wp, 0.3_wp, 0.2_wp], [0.0_wp, 0.0_wp, &
                0.0_wp, 0.0_wp], q, p)
            allocate (sys, source=chain)
        case ("dumbbell")
            dumbbell = sphere_dumbbell()
            allocate (q(6), p(6))
            call dumbbell%initial_state(q, p)
            allocate (sys, source=dumbbell)
        case ("magnetic")
            magnetic = magnetic_sphere()
            allocate (q(3), p(3))
            call magnetic%initial_state(q, p)
            allocate (sys, source=magnetic)
        case ("generic")
            generic = generic_pendulum()
            allocate (q(3), p(3))
            call generic%initial_state(q, p)
            allocate (sys, source=generic)
        end select
    end subroutine builtin_system

end module holosym_test_systems
