!> The systems the `holosym` command and the tests know by name, each with its initial
!! state: the spherical pendulum (paper Example 1), the spring-linkage mechanism (Example 2),
!! the planar pendulum, the chain of K planar pendula (unit masses and lengths, g = 1,
!! every link at 0.5 rad from the downward vertical and at rest), and the catalogue beyond
!! the paper: the double pendulum, two bodies on a sphere joined by a rod, a charged
!! particle on a sphere in a magnetic field and a spherical pendulum in a generic
!! potential. Internal: no stability promise.
module holosym_study_systems
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_model_dumbbell, only: sphere_dumbbell
    use holosym_model_magnetic, only: magnetic_sphere
    use holosym_model_generic, only: generic_pendulum
    implicit none
    private

    public :: make_system, is_system_name, reference_state

    !> The names, in the order of the help texts; the first is the default of the commands.
    character(len=*), parameter, public :: system_names(*) = [character(len=8) :: &
        "pendulum", "linkage", "planar", "chain", "double", "dumbbell", "magnetic", "generic"]
    !> The names as a message lists them.
    character(len=*), parameter, public :: system_choices = &
        "pendulum, linkage, planar, chain, double, dumbbell, magnetic or generic"
    !> Links of the chain when none are given, and the range accepted (n = 2K unknowns
    !! per node; the reduced step's cost and memory grow linearly with K).
    integer, parameter, public :: default_links = 8, max_links = 100000
    !> Angle of every link of the chain at t = 0 (from the downward vertical, radians).
    real(wp), parameter :: chain_angle = 0.5_wp
    !> Link angles (from the downward vertical) and angular velocities of the double
    !! pendulum's start.
    real(wp), parameter :: double_angles(2) = [1.0_wp, 0.5_wp]
    real(wp), parameter :: double_rates(2) = [0.0_wp, 0.0_wp]

contains

    !> Whether `name` is one of `system_names`.
    pure logical function is_system_name(name)
        character(len=*), intent(in) :: name !! a system name
        is_system_name = any(system_names == name)
    end function is_system_name

    !> The system called `name` and its initial state (`links`: the chain's K, default
    !! `default_links`, ignored by the other systems).
    !! Fails with HOLOSYM_INVALID_ARGUMENT for an unknown name or K outside 1..max_links.
    subroutine make_system(name, sys, q, p, status, links)
        character(len=*), intent(in) :: name  !! one of `system_names`
        class(constrained_hamiltonian), allocatable, intent(out) :: sys !! the system
        real(wp), allocatable, intent(out) :: q(:) !! initial coordinates (n)
        real(wp), allocatable, intent(out) :: p(:) !! initial momenta (n)
        type(holosym_status_t), intent(out) :: status !! outcome
        integer, intent(in), optional :: links !! K of the chain
        type(spherical_pendulum) :: sphere
        type(pendulum_chain) :: chain
        integer :: k
        type(spring_linkage) :: linkage
        type(planar_pendulum) :: planar
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
        case ("chain")
            k = default_links
            if (present(links)) k = links
            if (k < 1 .or. k > max_links) then
                status%code = HOLOSYM_INVALID_ARGUMENT
                status%message = "the chain needs 1 to " // int_str(max_links) // &
                    " links; got " // int_str(k)
                return
            end if
            chain = pendulum_chain(k)
            allocate (q(chain%n), p(chain%n))
            call chain%state_from_angles(spread(chain_angle, 1, k), spread(0.0_wp, 1, k), &
                                         q, p)
            allocate (sys, source=chain)
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

    !> A reference state at T = span from (q0, p0): `steps` steps of order 16, (8, 7, 9)
    !! ((6, 5, 7) in real64, where finer high-order steps stall Newton at round-off), and
    !! `difference`, its distance from the run with half the steps (the reference's
    !! convergence). Used by `holosym bench --accuracy` and the test suite `accuracy`.
    subroutine reference_state(sys, q0, p0, span, steps, q_ref, p_ref, difference, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:), p0(:) !! start state
        real(wp), intent(in) :: span         !! T
        integer, intent(in) :: steps         !! steps to T (even)
        real(wp), allocatable, intent(out) :: q_ref(:), p_ref(:) !! the state at T
        real(wp), intent(out) :: difference  !! max |reference - half-steps run|
        type(holosym_status_t), intent(out) :: status !! the failure of a run
        type(constrained_integrator) :: integ
        real(wp), allocatable :: q(:), p(:)
        integer :: order_m, run
        order_m = merge(6, 8, wp_is_double)
        difference = 0
        q_ref = q0
        p_ref = p0
        q = q0
        p = p0
        do run = 1, 2
            call integ%init(sys, order_m, order_m - 1, order_m + 1, status)
            if (.not. status%ok()) return
            if (run == 1) then
                call integ%integrate(sys, q_ref, p_ref, span / steps, steps, status=status)
            else
                call integ%integrate(sys, q, p, span / (steps / 2), steps / 2, status=status)
            end if
            if (.not. status%ok()) return
        end do
        difference = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
    end subroutine reference_state

end module holosym_study_systems
