!> The built-in systems of the tests by name, each with its documented start state: the
!! systems the `holosym` command knows by name (holosym_study_systems: pendulum, linkage,
!! planar, chain, double, dumbbell, magnetic, generic) and `chain4`, a chain of four links
!! released from 0.5, 0.4, 0.3, 0.2 rad (the reference solutions' chain); and
!! `uneven_chain`, four links of unequal masses and lengths in motion (the comparisons of
!! paths and iterations).
module holosym_test_systems
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t
    use holosym_problem, only: constrained_hamiltonian
    use holosym_model_chain, only: pendulum_chain
    use holosym_study_systems, only: make_system
    use holosym_models, only: spherical_pendulum, spring_linkage
    implicit none
    private
    public :: builtin_system, paper_start, uneven_chain

contains

    !> The system called `name` and its start; `sys` is not allocated for an unknown name.
    subroutine builtin_system(name, sys, q, p)
        character(len=*), intent(in) :: name !! a name of holosym_study_systems, or chain4
        class(constrained_hamiltonian), allocatable, intent(out) :: sys !! the system
        real(wp), allocatable, intent(out) :: q(:) !! initial coordinates
        real(wp), allocatable, intent(out) :: p(:) !! initial momenta
        type(pendulum_chain) :: chain
        type(holosym_status_t) :: status
        if (name == "chain4") then
            chain = pendulum_chain(4)
            allocate (q(8), p(8))
            call chain%state_from_angles([0.5_wp, 0.4_wp, 0.3_wp, 0.2_wp], [0.0_wp, 0.0_wp, &
                0.0_wp, 0.0_wp], q, p)
            allocate (sys, source=chain)
        else
            call make_system(name, sys, q, p, status)
        end if
    end subroutine builtin_system

    !> The paper's start state of either of its systems (spherical pendulum, spring
    !! linkage); q and p are left as they are for any other system.
    subroutine paper_start(sys, q, p)
        class(constrained_hamiltonian), intent(in) :: sys !! one of the paper's systems
        real(wp), intent(inout) :: q(:), p(:)             !! its start state
        select type (sys)
        type is (spherical_pendulum)
            call sys%initial_state(q, p)
        type is (spring_linkage)
            call sys%initial_state(q, p)
        end select
    end subroutine paper_start

    !> Four links of masses 1, 2, 1.5, 1 and lengths 1, 0.7, 0.5, 0.8 at angles 0.3, 0.5,
    !! -0.2, 0.1 rad with angular velocities 0, 0.8, 0.1, -0.3.
    subroutine uneven_chain(chain, q, p)
        type(pendulum_chain), intent(out) :: chain
        real(wp), intent(out) :: q(8), p(8)
        chain = pendulum_chain(4, masses=[1.0_wp, 2.0_wp, 1.5_wp, 1.0_wp], &
                               lengths=[1.0_wp, 0.7_wp, 0.5_wp, 0.8_wp])
        call chain%state_from_angles([0.3_wp, 0.5_wp, -0.2_wp, 0.1_wp], &
                                     [0.0_wp, 0.8_wp, 0.1_wp, -0.3_wp], q, p)
    end subroutine uneven_chain

end module holosym_test_systems
