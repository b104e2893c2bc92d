!> The system a command runs: one of the systems known by name (holosym_study_systems,
!! which the tests share; re-exported here) or a model file. Every command and study that
!! takes a system name gets the model here.
!!
!! A command that takes a system also takes a model file instead (`--model FILE`, with
!! `--set NAME=VALUE` for its parameters): `system_source_t` parses those options once for
!! every command, and `make_source_system` gives the system and its initial state from
!! either.
module holosym_systems
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_formula_model, only: formula_model, load_model
    use holosym_cli_common, only: parse_real, parse_integer, fail
    use holosym_study_systems, only: make_system, is_system_name, system_names, &
        system_choices, default_links, max_links
    implicit none
    private

    public :: make_source_system
    ! The systems known by name (holosym_study_systems).
    public :: make_system, is_system_name, system_names, system_choices, default_links, &
        max_links

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

end module holosym_systems

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_systems) holosym_systems_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_systems_app
