!> The systems the `holosym` command knows by name, each with its initial state: the
!! spherical pendulum (paper Example 1), the spring-linkage mechanism (Example 2), the
!! planar pendulum, the chain of K planar pendula (unit masses and lengths, g = 1,
!! every link at 0.5 rad from the downward vertical and at rest), and the catalogue beyond
!! the paper: the double pendulum, two bodies on a sphere joined by a rod, a charged
!! particle on a sphere in a magnetic field and a spherical pendulum in a generic
!! potential. Every command and study that takes a system name gets the model here.
!!
!! A command that takes a system also takes a model file instead (`--model FILE`, with
!! `--set NAME=VALUE` for its parameters): `system_source_t` parses those options once for
!! every command, and `make_source_system` gives the system and its initial state from
!! either.
module holosym_systems
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_formula_model, only: formula_model, load_model
    use holosym_cli_common, only: parse_real, parse_integer, fail
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_model_dumbbell, only: sphere_dumbbell
    use holosym_model_magnetic, only: magnetic_sphere
    use holosym_model_generic, only: generic_pendulum
    implicit none
    private

    public :: make_system, is_system_name, make_source_system

    !> One --set NAME=VALUE.
    type :: parameter_setting_t
        character(len=:), allocatable :: name
        character(len=:), allocatable :: text !! the value as given
        real(wp) :: value = 0
    end type parameter_setting_t

    !> The system a command runs: a built-in one by name (--system, --links) or a model
    !! file (--model) with parameters set by name (--set).
    type, public :: system_source_t
        !> The built-in system's name (when no model is given).
        character(len=:), allocatable :: name
        !> The model file, "" for a built-in system.
        character(len=:), allocatable :: model
        !> Links of the chain (--links, only with --system chain).
        integer :: links = 0
        !> The --set options, in order.
        type(parameter_setting_t), allocatable :: settings(:)
        logical :: system_given = .false.
        logical :: links_given = .false.
    contains
        !> Take one of --system, --model, --set, --links; false for any other option.
        procedure :: take => source_take
        !> After the options: they must fit together.
        procedure :: check => source_check
        !> "pendulum" or "model FILE", for messages and headers.
        procedure :: label => source_label
    end type system_source_t

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

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> Take the option `option` with its value, when it is one of --system, --model, --set
    !! and --links (`taken`); `allowed` lists the built-in names the command accepts
    !! (default all) and `choices` says them in a message.
    subroutine source_take(self, option, value, taken, status, allowed, choices)
        class(system_source_t), intent(inout) :: self
        character(len=*), intent(in) :: option   !! the option as written
        character(len=*), intent(in) :: value    !! its value
        logical, intent(out) :: taken            !! whether it was a system option
        type(holosym_status_t), intent(out) :: status !! a failure names the option
        character(len=*), intent(in), optional :: allowed(:) !! built-in names accepted
        character(len=*), intent(in), optional :: choices    !! those names for a message
        integer :: equals
        real(wp) :: number
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        if (.not. allocated(self%name)) self%name = system_names(1)
        if (.not. allocated(self%model)) self%model = ""
        if (.not. allocated(self%settings)) allocate (self%settings(0))
        taken = .true.
        select case (option)
        case ("--system")
            if (.not. is_system_name(value)) then
                call fail(status, "option --system: unknown system '" // value // &
                    "'; choose " // system_choices)
            else if (present(allowed)) then
                if (.not. any(allowed == value)) call fail(status, "option --system: '" // &
                    value // "' is not available here; choose " // choices)
            end if
            self%name = value
            self%system_given = .true.
        case ("--model")
            self%model = value
        case ("--set")
            equals = index(value, "=")
            if (equals < 2 .or. equals == len(value)) then
                call fail(status, "option --set expects NAME=VALUE (a parameter of the " // &
                    "model and a number); got '" // value // "'")
                return
            end if
            call parse_real("--set " // value(:equals - 1), value(equals + 1:), number, status)
            if (.not. status%ok()) return
            call add_setting(self, value(:equals - 1), value(equals + 1:), number)
        case ("--links")
            call parse_integer(option, value, self%links, status)
            if (status%ok() .and. (self%links < 1 .or. self%links > max_links)) &
                call fail(status, "option --links must be in 1.." // int_str(max_links) // &
                    "; got '" // value // "'")
            self%links_given = .true.
        case default
            taken = .false.
        end select
    end subroutine source_take

    !> Append a --set.
    subroutine add_setting(self, name, text, value)
        class(system_source_t), intent(inout) :: self
        character(len=*), intent(in) :: name, text
        real(wp), intent(in) :: value
        type(parameter_setting_t), allocatable :: longer(:)
        integer :: k
        allocate (longer(size(self%settings) + 1))
        do k = 1, size(self%settings)
            call move_alloc(self%settings(k)%name, longer(k)%name)
            call move_alloc(self%settings(k)%text, longer(k)%text)
            longer(k)%value = self%settings(k)%value
        end do
        longer(size(longer))%name = name
        longer(size(longer))%text = text
        longer(size(longer))%value = value
        call move_alloc(longer, self%settings)
    end subroutine add_setting

    !> The options must fit together: --system or --model, --set with --model, --links
    !! with --system chain.
    subroutine source_check(self, status)
        class(system_source_t), intent(inout) :: self
        type(holosym_status_t), intent(inout) :: status !! set on a failure
        if (.not. allocated(self%name)) self%name = system_names(1)
        if (.not. allocated(self%model)) self%model = ""
        if (.not. allocated(self%settings)) allocate (self%settings(0))
        if (.not. status%ok()) return
        if (len(self%model) > 0 .and. self%system_given) then
            call fail(status, "options --system and --model: give one or the other")
        else if (size(self%settings) > 0 .and. len(self%model) == 0) then
            call fail(status, "option --set sets a parameter of a model: it needs --model")
        else if (self%links_given .and. (len(self%model) > 0 .or. self%name /= "chain")) then
            call fail(status, "option --links needs --system chain")
        end if
    end subroutine source_check

    !> "pendulum" or "model FILE".
    function source_label(self) result(text)
        class(system_source_t), intent(in) :: self
        character(len=:), allocatable :: text
        if (allocated(self%model)) then
            if (len(self%model) > 0) then
                text = "model " // self%model
                return
            end if
        end if
        text = system_names(1)
        if (allocated(self%name)) text = self%name
    end function source_label

    !> The system of `source` and its initial state: the built-in one, or the model file
    !! loaded, its parameters set and its initial state made consistent (`note` says when
    !! it was projected onto the constraint manifold, "" otherwise). Fails with the
    !! model's message (HOLOSYM_INVALID_MODEL for a file refused), HOLOSYM_INVALID_ARGUMENT
    !! for a --set the model does not have, or a model without an initial state.
    subroutine make_source_system(source, sys, q, p, status, note, identity)
        type(system_source_t), intent(in) :: source !! what the options chose
        class(constrained_hamiltonian), allocatable, intent(out) :: sys !! the system
        real(wp), allocatable, intent(out) :: q(:) !! initial coordinates (n)
        real(wp), allocatable, intent(out) :: p(:) !! initial momenta (n)
        type(holosym_status_t), intent(out) :: status !! outcome
        character(len=:), allocatable, intent(out) :: note !! what was done to the start
        !> What identifies the system in a results file: the name, or the model file with
        !! the digest of its text and the parameters set.
        character(len=:), allocatable, intent(out), optional :: identity
        type(formula_model) :: model
        integer :: k
        note = ""
        if (present(identity)) identity = source%label()
        if (len(source%model) == 0) then
            if (source%links_given) then
                call make_system(source%name, sys, q, p, status, source%links)
            else
                call make_system(source%name, sys, q, p, status)
            end if
            return
        end if
        call load_model(source%model, model, status)
        if (.not. status%ok()) return
        do k = 1, size(source%settings)
            call model%set_parameter(source%settings(k)%name, source%settings(k)%value, status)
            if (.not. status%ok()) then
                status%message = "option --set " // source%settings(k)%name // "=" // &
                    source%settings(k)%text // ": " // status%message
                return
            end if
        end do
        if (present(identity)) then
            identity = identity // " text=" // model%text_digest()
            do k = 1, size(source%settings)
                identity = identity // " " // source%settings(k)%name // "=" // &
                    real_str(source%settings(k)%value)
            end do
        end if
        allocate (q(model%n), p(model%n))
        call model%initial_state(q, p, status, note)
        if (.not. status%ok()) then
            deallocate (q, p)
            return
        end if
        allocate (sys, source=model)
    end subroutine make_source_system

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

end module holosym_systems

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_systems) holosym_systems_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_systems_app
