!> category: public module (use holosym)
!! A section is a surface g(q, p) = 0 of the state space, stated as an expression in the
!! grammar of model files, whose crossings by the motion are events (`holosym_events`):
!! a Poincare section is the set of states where the motion crosses it in one direction.
!!
!! `make_section(sys, expression, direction, section, status)` compiles the expression for
!! the system `sys`: over q1..qn and p1..pn for every system, and for a model file's system
!! (`formula_model`) also over the model's own names (coordinates, momenta, parameters,
!! `let`s; q_i and p_i stand for the model's i-th coordinate and momentum unless the model
!! uses those names itself, in which case they are the model's). The section is an `event_set` of one function, to give to
!! `integrate_events` or to an ensemble (`ensemble_settings_t%section`).
module holosym_sections
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, append_numbered, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_formula_model, only: formula_model, model_from_text
    use holosym_events, only: event_set, EVENT_ANY, EVENT_RISING, EVENT_FALLING
    implicit none
    private

    public :: section_t, make_section

    !> The statement's start before the expression: columns of the expression in the
    !! parser's messages are shifted by its length.
    character(len=*), parameter :: statement_start = "event section: "

    !> A section: one event function, its expression compiled as the only `event` of a
    !! model (over the system's names), and the direction of the crossings wanted.
    type, extends(event_set) :: section_t
        !> The expression as given.
        character(len=:), allocatable :: expression
        !> EVENT_RISING, EVENT_FALLING or EVENT_ANY.
        integer :: wanted = EVENT_ANY
        !> Holds the compiled expression: its last event (after a model's own).
        type(formula_model), private :: model
    contains
        procedure :: count => section_count
        procedure :: value => section_value
        procedure :: direction => section_direction
    end type section_t

contains

    !> The section `expression` = 0 of the system `sys`, crossed in `direction`
    !! (EVENT_RISING: g from negative to positive, EVENT_FALLING, EVENT_ANY).
    !! Codes: HOLOSYM_INVALID_ARGUMENT (a direction other than -1, 0, 1; an empty
    !! expression), HOLOSYM_INVALID_MODEL (the expression does not parse, names something
    !! the system does not have, or depends on no coordinate or momentum: the message
    !! gives the column in the expression and what was expected).
    subroutine make_section(sys, expression, direction, section, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        character(len=*), intent(in) :: expression        !! g(q, p), model-file grammar
        integer, intent(in) :: direction                  !! crossings wanted
        type(section_t), intent(out) :: section           !! the section
        type(holosym_status_t), intent(out) :: status     !! outcome
        character(len=:), allocatable :: before
        integer :: lines
        if (all(direction /= [EVENT_ANY, EVENT_RISING, EVENT_FALLING])) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "the direction of a section " // &
                "must be EVENT_ANY (0), EVENT_RISING (1) or EVENT_FALLING (-1); got " // &
                int_str(direction))
            return
        end if
        if (len_trim(expression) == 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "the section's expression " // &
                "is empty: give g(q, p), e.g. 'q1' or 'q3 - 0.75'")
            return
        end if
        section%expression = trim(expression)
        section%wanted = direction
        select type (sys)
        type is (formula_model)
            before = aliases(sys)
            call sys%extended(before // statement_start // section%expression, &
                              section%model, status)
            if (.not. status%ok() .and. len(before) > 0) then
                ! A `let` of the model may take a name q_i or p_i: the model's names alone.
                before = ""
                call sys%extended(statement_start // section%expression, section%model, &
                                  status)
            end if
            lines = sys%line_count() + line_count(before)
        class default
            before = variables_text(sys%n)
            call model_from_text(before // statement_start // section%expression, &
                                 section%model, status, name="section")
            lines = line_count(before)
        end select
        if (.not. status%ok()) status%message = section_message(section%expression, &
            status%message, lines + 1)
    end subroutine make_section

    !> The statements that name the variables q1..qn, p1..pn of a system given by
    !! procedures (its H is not the section's business: 0).
    function variables_text(n) result(text)
        integer, intent(in) :: n
        character(len=:), allocatable :: text
        text = "coordinates "
        call append_numbered(text, "q", n, " ")
        text = text // new_line("a") // "momenta "
        call append_numbered(text, "p", n, " ")
        text = text // new_line("a") // "hamiltonian 0" // new_line("a")
    end function variables_text

    !> `let q_i = <coordinate i>` (and p_i) for the names q_i, p_i the model does not use.
    function aliases(model) result(text)
        type(formula_model), intent(in) :: model
        character(len=:), allocatable :: text
        integer :: i
        text = ""
        do i = 1, model%n
            if (.not. used(model, "q" // int_str(i))) text = text // "let q" // &
                int_str(i) // " = " // model%coordinate_name(i) // new_line("a")
            if (.not. used(model, "p" // int_str(i))) text = text // "let p" // &
                int_str(i) // " = " // model%momentum_name(i) // new_line("a")
        end do
    end function aliases

    !> Whether the model names a coordinate, momentum or parameter `name`.
    logical function used(model, name)
        type(formula_model), intent(in) :: model
        character(len=*), intent(in) :: name
        integer :: k
        used = .false.
        do k = 1, model%n
            used = used .or. model%coordinate_name(k) == name .or. &
                model%momentum_name(k) == name
        end do
        do k = 1, model%parameter_count()
            used = used .or. model%parameter_name(k) == name
        end do
    end function used

    !> Lines of `text` (each ended by a line feed).
    pure integer function line_count(text)
        character(len=*), intent(in) :: text
        integer :: k
        line_count = 0
        do k = 1, len(text)
            if (text(k:k) == new_line("a")) line_count = line_count + 1
        end do
    end function line_count

    !> The parser's message "SOURCE:LINE:COLUMN: what" about the section's statement (line
    !! `line`) as "section 'EXPR': column C: what", C counted in the expression; other
    !! messages are prefixed with "section 'EXPR': ".
    function section_message(expression, message, line) result(text)
        character(len=*), intent(in) :: expression, message
        integer, intent(in) :: line
        character(len=:), allocatable :: text
        character(len=:), allocatable :: place
        integer :: at, column, ios, finish
        text = "section '" // expression // "': "
        place = ":" // int_str(line) // ":"
        at = index(message, place)
        if (at == 0) then
            text = text // message
            return
        end if
        finish = index(message(at + len(place):), ":")
        column = 0
        ios = 1
        if (finish > 1) read (message(at + len(place):at + len(place) + finish - 2), *, &
                              iostat=ios) column
        if (ios /= 0) then
            text = text // message
            return
        end if
        column = max(1, column - len(statement_start))
        text = text // "column " // int_str(column) // ":" // &
            message(at + len(place) + finish:)
    end function section_message

    integer function section_count(self)
        class(section_t), intent(in) :: self
        section_count = 1
        if (len(self%expression) < 0) continue
    end function section_count

    !> g(q, p) of the section (k = 1; t unused: sections are surfaces of the state space).
    real(wp) function section_value(self, k, t, q, p) result(g)
        class(section_t), intent(in) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: t, q(:), p(:)
        real(wp) :: values(self%model%event_count())
        call self%model%event_values(q, p, values)
        g = values(size(values))
        if (k < 0 .and. t < 0) continue
    end function section_value

    integer function section_direction(self, k)
        class(section_t), intent(in) :: self
        integer, intent(in) :: k
        section_direction = self%wanted
        if (k < 0) continue
    end function section_direction

end module holosym_sections
