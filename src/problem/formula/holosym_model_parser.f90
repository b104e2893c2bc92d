!> category: internal module (use holosym)
!! The reader of model files: text in, a `model_definition_t` out (the names, the
!! expression graph of H, of each constraint and of the initial state), or the first error
!! with its file, line and column and what was expected.
!!
!! The grammar (docs/models.md has it with examples and every error):
!!
!!     file       = { line }            one statement a line; '#' starts a comment; a line
!!                                      ending in '\' continues on the next
!!     statement  = "parameters" assignments | "coordinates" names | "momenta" names
!!                | "let" assignments | "hamiltonian" expression | "constraint" expression
!!                | "initial" assignments | "velocity" assignments
!!     names      = name { [","] name }
!!     assignments = name "=" expression { [","] name "=" expression }
!!     expression = term { ("+" | "-") term }
!!     term       = factor { ("*" | "/") factor }
!!     factor     = ("-" | "+") factor | primary [ ("^" | "**") factor ]
!!     primary    = number | name | function "(" expression { "," expression } ")"
!!                | "(" expression ")"
!!
!! Names are defined before they are used; a number is a decimal read in working
!! precision. `coordinates` comes before `momenta` (one statement each), and the two name
!! the same number of variables.
module holosym_model_parser
    use holosym_kinds, only: wp
    use holosym_status_codes, only: int_str
    use holosym_decimal, only: read_decimal, number_ok, number_out_of_range
    use holosym_text_file, only: text_line_t, max_text_line_length, control_position
    use holosym_expression, only: expression_graph_t, node_zero, op_negate, op_add, &
        op_subtract, op_multiply, op_divide, op_power, op_sqrt, op_exp, op_log, op_sin, &
        op_cos, op_tan, op_atan, op_sinh, op_cosh, op_tanh, op_asin, op_acos, op_atan2
    implicit none
    private

    public :: model_definition_t, name_t, parse_model, split_text

    !> Deepest nesting of an expression (parentheses, signs, powers).
    integer, parameter, public :: max_nesting = 256
    !> Longest statement, continuation lines joined (characters).
    integer, parameter, public :: max_statement_length = 4 * max_text_line_length

    !> What a name stands for.
    integer, parameter, public :: name_coordinate = 1, name_momentum = 2, &
        name_parameter = 3, name_let = 4

    !> The statements' keywords.
    character(len=*), parameter :: keywords(*) = [character(len=12) :: "parameters", &
        "parameter", "coordinates", "momenta", "let", "hamiltonian", "constraint", &
        "initial", "velocity", "velocities", "event"]
    !> The functions and how many arguments each takes (atan also 2: atan(y, x)).
    character(len=*), parameter :: functions(*) = [character(len=5) :: "sqrt", "exp", &
        "log", "sin", "cos", "tan", "atan", "sinh", "cosh", "tanh", "asin", "acos", "atan2"]
    integer, parameter :: function_ops(*) = [op_sqrt, op_exp, op_log, op_sin, op_cos, &
        op_tan, op_atan, op_sinh, op_cosh, op_tanh, op_asin, op_acos, op_atan2]

    !> Token kinds.
    integer, parameter :: tk_end = 0, tk_name = 1, tk_number = 2, tk_symbol = 3

    !> A name.
    type :: name_t
        character(len=:), allocatable :: text
    end type name_t

    !> A model as the file states it.
    type :: model_definition_t
        !> The file name (or the name given to text) used in messages.
        character(len=:), allocatable :: source
        !> The expressions.
        type(expression_graph_t) :: graph
        !> Coordinates and momenta, in declaration order (variables 1..n and n+1..2n).
        type(name_t), allocatable :: coordinates(:), momenta(:)
        !> Parameters: names, the node of each definition, the value at definition.
        type(name_t), allocatable :: parameters(:)
        integer, allocatable :: parameter_definitions(:)
        real(wp), allocatable :: parameter_values(:)
        !> H and its line.
        integer :: hamiltonian = 0
        integer :: hamiltonian_line = 0
        !> The constraints and their lines.
        integer, allocatable :: constraints(:), constraint_lines(:)
        !> The initial state: a node for each coordinate and momentum (or velocity), 0 where
        !! not given; `velocities` when the momenta were given as velocities.
        integer, allocatable :: initial_q(:), initial_p(:)
        logical :: velocities = .false.
        logical :: has_initial = .false.
        integer :: initial_line = 0
        !> Events: names, expressions, directions (-1, 0, 1), whether each ends a run.
        type(name_t), allocatable :: event_names(:)
        integer, allocatable :: events(:), event_directions(:)
        logical, allocatable :: event_stops(:)
    end type model_definition_t

    !> One statement: continuation lines joined, comments removed, and for each character
    !! the line and column it came from.
    type :: statement_t
        character(len=:), allocatable :: text
        integer, allocatable :: line(:), column(:)
        integer :: first_line = 0
    end type statement_t

    !> The symbol table: an open-addressing map from names to (kind, index).
    type :: symbols_t
        type(name_t), allocatable :: names(:)
        integer, allocatable :: kind(:), index(:), line(:), table(:)
        integer :: count = 0
    end type symbols_t

    !> The state of a parse.
    type :: parser_t
        type(statement_t), allocatable :: statements(:)
        integer :: current = 0              ! index of the statement being parsed
        integer :: position = 1             ! next character of its text
        integer :: token = tk_end           ! the current token
        integer :: token_start = 1, token_end = 0
        integer :: depth = 0
        type(symbols_t) :: symbols
        logical :: failed = .false.
        character(len=:), allocatable :: message
        character(len=:), allocatable :: defining ! the name whose value is being parsed
    end type parser_t

contains

    ! ------------------------------------------------------------------ entry point

    !> Parse the lines of a model. On success `ok` is true; otherwise `message` is
    !! "SOURCE:LINE:COLUMN: what is wrong" (or "SOURCE: ..." for the model as a whole).
    subroutine parse_model(lines, source, model, ok, message)
        type(text_line_t), intent(in) :: lines(:) !! the text, line by line
        character(len=*), intent(in) :: source    !! the name used in messages
        type(model_definition_t), intent(out) :: model !! the model
        logical, intent(out) :: ok                !! whether it parsed
        character(len=:), allocatable, intent(out) :: message !! "" or the error
        type(parser_t) :: parser
        integer :: k
        model%source = source
        message = ""
        call model%graph%init()
        allocate (model%coordinates(0), model%momenta(0), model%parameters(0), &
                  model%parameter_definitions(0), model%parameter_values(0), &
                  model%constraints(0), model%constraint_lines(0), model%event_names(0), &
                  model%events(0), model%event_directions(0), model%event_stops(0))
        call init_symbols(parser%symbols)
        call join_statements(lines, parser)
        do k = 1, size(parser%statements)
            if (parser%failed) exit
            parser%current = k
            call parse_statement(parser, model)
        end do
        if (.not. parser%failed) call check_complete(parser, model, size(lines))
        ok = .not. parser%failed
        if (.not. ok) message = source // ":" // parser%message
    end subroutine parse_model

    !> Split text into lines at line feeds (a last line without one is kept).
    subroutine split_text(text, lines)
        character(len=*), intent(in) :: text           !! the text
        type(text_line_t), allocatable, intent(out) :: lines(:) !! its lines
        integer :: count, first, k, last
        count = 0
        do k = 1, len(text)
            if (text(k:k) == new_line("a")) count = count + 1
        end do
        if (len(text) > 0) then
            if (text(len(text):len(text)) /= new_line("a")) count = count + 1
        end if
        allocate (lines(count))
        first = 1
        do k = 1, count
            last = index(text(first:), new_line("a"))
            if (last == 0) then
                last = len(text)
            else
                last = first + last - 2
            end if
            lines(k)%text = text(first:last)
            first = last + 2
        end do
    end subroutine split_text

    ! ------------------------------------------------------------------ statements

    !> Join continuation lines, drop comments and blank lines, check the characters.
    subroutine join_statements(lines, parser)
        type(text_line_t), intent(in) :: lines(:)
        type(parser_t), intent(inout) :: parser
        type(statement_t), allocatable :: kept(:)
        type(statement_t) :: open_statement
        integer :: k, count, last, bad
        character(len=:), allocatable :: text
        logical :: continues
        allocate (kept(16), parser%statements(0))
        count = 0
        open_statement%text = ""
        allocate (open_statement%line(0), open_statement%column(0))
        do k = 1, size(lines)
            text = lines(k)%text
            if (len(text) > max_text_line_length) then
                call fail_at(parser, k, 1, "the line is longer than " // &
                    int_str(max_text_line_length) // " characters")
                return
            end if
            if (len(text) > 0) then
                if (text(len(text):len(text)) == achar(13)) text = text(:len(text) - 1)
            end if
            last = index(text, "#") - 1
            if (last < 0) last = len(text)
            bad = control_position(text(:last))
            if (bad > 0) then
                call fail_at(parser, k, bad, "not text: control character " // &
                    int_str(iachar(text(bad:bad))) // " (a model file is plain text)")
                return
            end if
            last = len_trim(text(:last))
            continues = .false.
            if (last > 0) continues = text(last:last) == "\"
            if (continues) last = last - 1
            if (len_trim(text(:last)) > 0 .or. continues) then
                if (len(open_statement%text) == 0) open_statement%first_line = k
                if (len(open_statement%text) + last + 1 > max_statement_length) then
                    call fail_at(parser, k, 1, "the statement is longer than " // &
                        int_str(max_statement_length) // " characters")
                    return
                end if
                call append(open_statement, text(:last) // " ", k)
            end if
            if (.not. continues .and. len_trim(open_statement%text) > 0) call keep()
        end do
        if (len_trim(open_statement%text) > 0) call keep()
        parser%statements = kept(:count)
    contains
        subroutine keep()
            type(statement_t), allocatable :: larger(:)
            if (count == size(kept)) then
                allocate (larger(2 * count))
                larger(:count) = kept(:count)
                call move_alloc(larger, kept)
            end if
            count = count + 1
            kept(count) = open_statement
            open_statement%text = ""
            deallocate (open_statement%line, open_statement%column)
            allocate (open_statement%line(0), open_statement%column(0))
        end subroutine keep
    end subroutine join_statements

    !> Append the characters of physical line `line` to a statement.
    subroutine append(statement, text, line)
        type(statement_t), intent(inout) :: statement
        character(len=*), intent(in) :: text
        integer, intent(in) :: line
        integer :: k
        statement%text = statement%text // text
        statement%line = [statement%line, (line, k = 1, len(text))]
        statement%column = [statement%column, (k, k = 1, len(text))]
    end subroutine append


    !> Parse the current statement into the model.
    subroutine parse_statement(parser, model)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        character(len=:), allocatable :: keyword, written
        parser%position = 1
        parser%depth = 0
        call next_token(parser)
        if (parser%failed) return
        if (parser%token /= tk_name) then
            call fail_token(parser, "expected a statement (" // keyword_list() // ")")
            return
        end if
        written = token_text(parser)
        keyword = lower(written)
        call next_token(parser)
        if (parser%failed) return
        select case (keyword)
        case ("parameters", "parameter")
            call parse_assignments(parser, model, name_parameter)
        case ("coordinates")
            call parse_variables(parser, model, name_coordinate)
        case ("momenta")
            call parse_variables(parser, model, name_momentum)
        case ("let")
            call parse_assignments(parser, model, name_let)
        case ("hamiltonian")
            call parse_hamiltonian(parser, model)
        case ("constraint")
            call parse_constraint(parser, model)
        case ("initial")
            call parse_initial(parser, model, .false.)
        case ("velocity", "velocities")
            call parse_initial(parser, model, .true.)
        case ("event")
            call parse_event(parser, model)
        case default
            call fail_at_statement(parser, "unknown statement '" // written // &
                "'" // suggestion(keyword, keywords) // "; expected " // keyword_list())
        end select
    end subroutine parse_statement

    !> Text in lower case (keywords are read in any case).
    pure function lower(text) result(out)
        character(len=*), intent(in) :: text
        character(len=len(text)) :: out
        integer :: k
        out = text
        do k = 1, len(text)
            if (text(k:k) >= "A" .and. text(k:k) <= "Z") out(k:k) = achar(iachar(text(k:k)) + 32)
        end do
    end function lower

    !> The keywords as a message lists them.
    pure function keyword_list() result(text)
        character(len=:), allocatable :: text
        text = "parameters, coordinates, momenta, let, hamiltonian, constraint, initial, " // &
            "velocity or event"
    end function keyword_list

    !> `coordinates NAMES` or `momenta NAMES`.
    subroutine parse_variables(parser, model, kind)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        integer, intent(in) :: kind
        character(len=:), allocatable :: what
        type(name_t), allocatable :: names(:)
        integer :: first_line, first_column
        what = "momenta"
        if (kind == name_coordinate) what = "coordinates"
        call token_position(parser, first_line, first_column)
        if (kind == name_coordinate .and. size(model%coordinates) > 0) then
            call fail_at_statement(parser, "the coordinates are declared already " // &
                "(line " // int_str(symbol_line(parser, model%coordinates(1)%text)) // &
                "): one coordinates statement (continue it with '\')")
            return
        end if
        if (kind == name_momentum) then
            if (size(model%momenta) > 0) then
                call fail_at_statement(parser, "the momenta are declared already " // &
                    "(line " // int_str(symbol_line(parser, model%momenta(1)%text)) // &
                    "): one momenta statement (continue it with '\')")
                return
            end if
            if (size(model%coordinates) == 0) then
                call fail_at_statement(parser, "momenta before coordinates: declare " // &
                    "the coordinates first")
                return
            end if
        end if
        allocate (names(0))
        do while (parser%token /= tk_end)
            if (parser%token == tk_symbol) then
                if (token_text(parser) == "," .and. size(names) > 0) then
                    call next_token(parser)
                    if (parser%failed) return
                    cycle
                end if
            end if
            if (parser%token /= tk_name) then
                call fail_token(parser, "expected a name of " // what)
                return
            end if
            call declare(parser, token_text(parser), kind, size(names) + 1)
            if (parser%failed) return
            call append_name(names, token_text(parser))
            call next_token(parser)
            if (parser%failed) return
        end do
        if (size(names) == 0) then
            call fail_token(parser, "expected the names of the " // what)
            return
        end if
        if (kind == name_coordinate) then
            model%coordinates = names
        else
            if (size(names) /= size(model%coordinates)) then
                call fail_at(parser, first_line, first_column, int_str(size(names)) // &
                    " momenta for " // int_str(size(model%coordinates)) // &
                    " coordinates: give one momentum for each coordinate")
                return
            end if
            model%momenta = names
        end if
    end subroutine parse_variables

    !> `parameters NAME = EXPR, ...` or `let NAME = EXPR, ...`.
    subroutine parse_assignments(parser, model, kind)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        integer, intent(in) :: kind
        character(len=:), allocatable :: name, what
        integer :: node, name_line, name_column, k
        integer, allocatable :: variables(:)
        real(wp) :: x
        what = "let"
        if (kind == name_parameter) what = "parameter"
        do
            call expect_name(parser, "a " // what // " name")
            if (parser%failed) return
            name = token_text(parser)
            call token_position(parser, name_line, name_column)
            call next_token(parser)
            if (parser%failed) return
            call expect_symbol(parser, "=", "'=' after '" // name // "'")
            if (parser%failed) return
            parser%defining = name
            node = parse_expression(parser, model)
            parser%defining = ""
            if (parser%failed) return
            if (kind == name_parameter) then
                variables = model%graph%variables_of(node)
                if (size(variables) > 0) then
                    call fail_at(parser, name_line, name_column, "parameter '" // name // &
                        "' depends on " // variable_name(model, variables(1)) // &
                        ": a parameter is a constant")
                    return
                end if
            end if
            call declare_at(parser, name, kind, 0, name_line, name_column)
            if (parser%failed) return
            if (kind == name_parameter) then
                k = size(model%parameters) + 1
                parser%symbols%index(parser%symbols%count) = k
                call append_name(model%parameters, name)
                model%parameter_definitions = [model%parameter_definitions, node]
                x = 0
                model%parameter_values = [model%parameter_values, x]
            else
                parser%symbols%index(parser%symbols%count) = node
            end if
            if (parser%token == tk_end) return
            if (is_symbol(parser, ",")) then
                call next_token(parser)
                if (parser%failed) return
            end if
            if (parser%token == tk_end) then
                call fail_token(parser, "expected another " // what // " after ','")
                return
            end if
            if (parser%token /= tk_name) then
                call fail_token(parser, "expected ',' or the end of the line after the " // &
                    "value of '" // name // "'")
                return
            end if
        end do
    end subroutine parse_assignments

    !> `hamiltonian EXPR`.
    subroutine parse_hamiltonian(parser, model)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        integer :: node
        if (model%hamiltonian /= 0) then
            call fail_at_statement(parser, "a second hamiltonian (the first is at " // &
                "line " // int_str(model%hamiltonian_line) // ")")
            return
        end if
        node = parse_whole_expression(parser, model, "the Hamiltonian")
        if (parser%failed) return
        model%hamiltonian = node
        model%hamiltonian_line = parser%statements(parser%current)%first_line
    end subroutine parse_hamiltonian

    !> `constraint EXPR`: holonomic (coordinates only) and not constant.
    subroutine parse_constraint(parser, model)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        integer :: node, line, column
        integer, allocatable :: variables(:)
        call token_position(parser, line, column)
        node = parse_whole_expression(parser, model, "the constraint")
        if (parser%failed) return
        variables = model%graph%variables_of(node)
        if (size(variables) == 0) then
            call fail_at(parser, line, column, "the constraint depends on no coordinate")
            return
        end if
        if (variables(size(variables)) > size(model%coordinates)) then
            call fail_at(parser, line, column, "the constraint depends on momentum '" // &
                model%momenta(variables(size(variables)) - size(model%coordinates))%text // &
                "': constraints are holonomic (coordinates only)")
            return
        end if
        model%constraints = [model%constraints, node]
        model%constraint_lines = [model%constraint_lines, &
                                  parser%statements(parser%current)%first_line]
    end subroutine parse_constraint

    !> `event NAME: EXPR [rising | falling | any] [stop]`: a function of the state whose
    !! zero crossings are events (docs/events.md); the direction of the crossings wanted
    !! (default any) and whether one ends the run.
    subroutine parse_event(parser, model)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        character(len=:), allocatable :: name
        integer :: node, direction, line, column, k
        logical :: stops
        call expect_name(parser, "the event's name")
        if (parser%failed) return
        name = token_text(parser)
        do k = 1, size(model%event_names)
            if (model%event_names(k)%text /= name) cycle
            call fail_token(parser, "a second event '" // name // "'")
            return
        end do
        call next_token(parser)
        if (parser%failed) return
        call expect_symbol(parser, ":", "':' after the event's name")
        if (parser%failed) return
        call token_position(parser, line, column)
        if (parser%token == tk_end) then
            call fail_token(parser, "expected the expression of event '" // name // "'")
            return
        end if
        node = parse_expression(parser, model)
        if (parser%failed) return
        call event_options(parser, direction, stops)
        if (parser%failed) return
        if (size(model%graph%variables_of(node)) == 0) then
            call fail_at(parser, line, column, "event '" // name // "' depends on no " // &
                "coordinate or momentum")
            return
        end if
        model%event_names = [model%event_names, name_t(name)]
        model%events = [model%events, node]
        model%event_directions = [model%event_directions, direction]
        model%event_stops = [model%event_stops, stops]
    end subroutine parse_event

    !> The words after an event's expression: `rising`, `falling` or `any` (-1, 0, 1 in
    !! `direction`; default any) and `stop`, then the end of the line.
    subroutine event_options(parser, direction, stops)
        type(parser_t), intent(inout) :: parser
        integer, intent(out) :: direction
        logical, intent(out) :: stops
        direction = 0
        stops = .false.
        do while (parser%token == tk_name)
            select case (lower(token_text(parser)))
            case ("rising")
                direction = 1
            case ("falling")
                direction = -1
            case ("any")
                direction = 0
            case ("stop")
                stops = .true.
            case default
                call fail_token(parser, "expected rising, falling, any or stop")
                return
            end select
            call next_token(parser)
            if (parser%failed) return
        end do
        if (parser%token /= tk_end) call fail_token(parser, "expected an operator, " // &
            "rising, falling, any, stop or the end of the line")
    end subroutine event_options

    !> `initial NAME = EXPR, ...` (coordinates and momenta) or `velocity NAME = EXPR, ...`
    !! (coordinates: their velocities).
    subroutine parse_initial(parser, model, velocities)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        logical, intent(in) :: velocities
        character(len=:), allocatable :: name, targets
        integer :: symbol, node, line, column, n
        integer, allocatable :: variables(:)
        n = size(model%coordinates)
        if (n == 0 .or. size(model%momenta) == 0) then
            call fail_at_statement(parser, "the initial state before the " // &
                "coordinates and momenta: declare them first")
            return
        end if
        if (.not. allocated(model%initial_q)) then
            allocate (model%initial_q(n), model%initial_p(n))
            model%initial_q = 0
            model%initial_p = 0
            model%initial_line = parser%statements(parser%current)%first_line
        end if
        model%has_initial = .true.
        targets = "coordinates and momenta"
        if (velocities) targets = "velocities of coordinates"
        do
            call expect_name(parser, "a name (the initial state gives " // targets // ")")
            if (parser%failed) return
            name = token_text(parser)
            call token_position(parser, line, column)
            symbol = find_symbol(parser%symbols, name)
            if (symbol == 0) then
                call fail_token(parser, "unknown name '" // name // "'" // &
                    suggestion(name, known_names(parser)) // "; the initial state gives " // &
                    targets)
                return
            end if
            if (parser%symbols%kind(symbol) /= name_coordinate .and. (velocities .or. &
                parser%symbols%kind(symbol) /= name_momentum)) then
                call fail_token(parser, "'" // name // "' is a " // &
                    kind_name(parser%symbols%kind(symbol)) // "; the initial state gives " // &
                    targets)
                return
            end if
            call next_token(parser)
            if (parser%failed) return
            call expect_symbol(parser, "=", "'=' after '" // name // "'")
            if (parser%failed) return
            node = parse_expression(parser, model)
            if (parser%failed) return
            variables = model%graph%variables_of(node)
            if (size(variables) > 0) then
                call fail_at(parser, line, column, "the initial value of '" // name // &
                    "' depends on " // variable_name(model, variables(1)) // &
                    ": initial values are constants")
                return
            end if
            call assign_initial(parser, model, symbol, node, velocities, line, column)
            if (parser%failed) return
            if (parser%token == tk_end) return
            if (is_symbol(parser, ",")) then
                call next_token(parser)
                if (parser%failed) return
            end if
            if (parser%token /= tk_name) then
                call fail_token(parser, "expected ',' or the end of the line after the " // &
                    "value of '" // name // "'")
                return
            end if
        end do
    end subroutine parse_initial

    !> Record an initial value, refusing a name given twice and momenta mixed with
    !! velocities.
    subroutine assign_initial(parser, model, symbol, node, velocities, line, column)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        integer, intent(in) :: symbol, node, line, column
        logical, intent(in) :: velocities
        integer :: k
        character(len=:), allocatable :: name
        k = parser%symbols%index(symbol)
        name = parser%symbols%names(symbol)%text
        if (parser%symbols%kind(symbol) == name_coordinate .and. .not. velocities) then
            if (model%initial_q(k) /= 0) then
                call fail_at(parser, line, column, "the initial value of '" // name // &
                    "' is given twice")
                return
            end if
            model%initial_q(k) = node
            return
        end if
        if (any(model%initial_p /= 0) .and. (model%velocities .neqv. velocities)) then
            call fail_at(parser, line, column, "the initial state gives both momenta and " // &
                "velocities: give one or the other (velocities go through " // &
                "state_from_velocities)")
            return
        end if
        if (model%initial_p(k) /= 0) then
            call fail_at(parser, line, column, "the initial value of '" // name // &
                "' is given twice")
            return
        end if
        model%initial_p(k) = node
        model%velocities = velocities
    end subroutine assign_initial

    !> After the last statement: what every model needs.
    subroutine check_complete(parser, model, lines)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        integer, intent(in) :: lines
        integer :: k, m, n
        if (size(parser%statements) == 0) then
            if (lines > 0) then
                call fail_model(parser, "the model is empty (" // int_str(lines) // &
                    " lines of comments and blanks): expected coordinates, momenta and " // &
                    "hamiltonian statements")
            else
                call fail_model(parser, "the model is empty: expected coordinates, " // &
                    "momenta and hamiltonian statements")
            end if
            return
        end if
        if (size(model%coordinates) == 0) then
            call fail_model(parser, "no coordinates statement: name the coordinates, " // &
                "e.g. 'coordinates x y'")
            return
        end if
        if (size(model%momenta) == 0) then
            call fail_model(parser, "no momenta statement: name the momenta, e.g. " // &
                "'momenta px py'")
            return
        end if
        if (model%hamiltonian == 0) then
            call fail_model(parser, "no hamiltonian statement: give H, e.g. " // &
                "'hamiltonian (px^2 + py^2)/2 + y'")
            return
        end if
        n = size(model%coordinates)
        m = size(model%constraints)
        if (m >= n) then
            call fail_at(parser, model%constraint_lines(m), 1, int_str(m) // &
                " constraints for " // int_str(n) // " coordinates: a system needs fewer " // &
                "constraints than coordinates")
            return
        end if
        if (model%has_initial) then
            do k = 1, n
                if (model%initial_q(k) == 0) then
                    call fail_at(parser, model%initial_line, 1, "the initial state gives " // &
                        "no value for coordinate '" // model%coordinates(k)%text // &
                        "' (every coordinate needs one; momenta and velocities default to 0)")
                    return
                end if
            end do
        end if
    end subroutine check_complete

    ! ------------------------------------------------------------------ expressions

    !> An expression that must fill the rest of the statement.
    integer function parse_whole_expression(parser, model, what) result(node)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        character(len=*), intent(in) :: what
        node = node_zero
        if (parser%token == tk_end) then
            call fail_token(parser, "expected the expression of " // what)
            return
        end if
        node = parse_expression(parser, model)
        if (parser%failed) return
        if (parser%token /= tk_end) call fail_token(parser, "expected an operator or " // &
            "the end of the line after the expression")
    end function parse_whole_expression

    !> expression = term { ("+" | "-") term }
    recursive integer function parse_expression(parser, model) result(node)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        node = parse_chain(parser, model, additive=.true.)
    end function parse_expression

    !> A left-associative chain of one precedence level: terms joined by + and -
    !! (`additive`), or factors joined by * and /.
    recursive integer function parse_chain(parser, model, additive) result(node)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        logical, intent(in) :: additive
        integer :: op, right, line, column
        node = operand()
        do while (.not. parser%failed)
            if (additive .and. is_symbol(parser, "+")) then
                op = op_add
            else if (additive .and. is_symbol(parser, "-")) then
                op = op_subtract
            else if (.not. additive .and. is_symbol(parser, "*")) then
                op = op_multiply
            else if (.not. additive .and. is_symbol(parser, "/")) then
                op = op_divide
            else
                exit
            end if
            call token_position(parser, line, column)
            call next_token(parser)
            if (parser%failed) return
            right = operand()
            if (parser%failed) return
            node = model%graph%binary(op, node, right)
            call model%graph%locate(node, line, column)
        end do
    contains
        !> term = factor { ("*" | "/") factor }, or a factor.
        recursive integer function operand()
            if (additive) then
                operand = parse_chain(parser, model, additive=.false.)
            else
                operand = parse_factor(parser, model)
            end if
        end function operand
    end function parse_chain

    !> factor = ("-" | "+") factor | primary [ ("^" | "**") factor ]
    recursive integer function parse_factor(parser, model) result(node)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        integer :: exponent, line, column
        node = node_zero
        parser%depth = parser%depth + 1
        if (parser%depth > max_nesting) then
            call fail_token(parser, "the expression is nested deeper than " // &
                int_str(max_nesting) // " levels")
            return
        end if
        if (is_symbol(parser, "-") .or. is_symbol(parser, "+")) then
            call token_position(parser, line, column)
            if (is_symbol(parser, "-")) then
                call next_token(parser)
                if (parser%failed) return
                node = parse_factor(parser, model)
                if (parser%failed) return
                node = model%graph%unary(op_negate, node)
                call model%graph%locate(node, line, column)
            else
                call next_token(parser)
                if (parser%failed) return
                node = parse_factor(parser, model)
            end if
        else
            node = parse_primary(parser, model)
            if (parser%failed) return
            if (is_symbol(parser, "^") .or. is_symbol(parser, "**")) then
                call token_position(parser, line, column)
                call next_token(parser)
                if (parser%failed) return
                exponent = parse_factor(parser, model)
                if (parser%failed) return
                node = model%graph%binary(op_power, node, exponent)
                call model%graph%locate(node, line, column)
            end if
        end if
        parser%depth = parser%depth - 1
    end function parse_factor

    !> primary = number | name | function "(" arguments ")" | "(" expression ")"
    recursive integer function parse_primary(parser, model) result(node)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        real(wp) :: x
        integer :: outcome
        node = node_zero
        select case (parser%token)
        case (tk_number)
            call read_decimal(token_text(parser), x, outcome)
            if (outcome == number_out_of_range) then
                call fail_token(parser, "the number " // token_text(parser) // " is out " // &
                    "of range (magnitudes from 1e-" // int_str(range(1.0_wp)) // " to 1e+" &
                    // int_str(range(1.0_wp)) // ", or 0)")
                return
            else if (outcome /= number_ok) then
                call fail_token(parser, "malformed number '" // token_text(parser) // "'")
                return
            end if
            node = model%graph%constant(x)
            call next_token(parser)
        case (tk_name)
            node = parse_name(parser, model)
        case (tk_symbol)
            if (is_symbol(parser, "(")) then
                call next_token(parser)
                if (parser%failed) return
                parser%depth = parser%depth + 1
                if (parser%depth > max_nesting) then
                    call fail_token(parser, "the expression is nested deeper than " // &
                        int_str(max_nesting) // " levels")
                    return
                end if
                node = parse_expression(parser, model)
                if (parser%failed) return
                call expect_symbol(parser, ")", "')'")
                parser%depth = parser%depth - 1
            else
                call fail_token(parser, "expected a number, a name or '('")
            end if
        case default
            call fail_token(parser, "expected a number, a name or '('")
        end select
    end function parse_primary

    !> A name in an expression: a variable, parameter, let, pi, or a function call.
    recursive integer function parse_name(parser, model) result(node)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        character(len=:), allocatable :: name
        integer :: symbol, f
        node = node_zero
        name = token_text(parser)
        f = function_index(name)
        if (f > 0) then
            node = parse_call(parser, model, f)
            return
        end if
        if (name == "pi") then
            node = model%graph%constant(4 * atan(1.0_wp))
            call next_token(parser)
            return
        end if
        symbol = find_symbol(parser%symbols, name)
        if (symbol == 0) then
            call fail_unknown(parser, name)
            return
        end if
        select case (parser%symbols%kind(symbol))
        case (name_coordinate)
            node = model%graph%variable(parser%symbols%index(symbol))
        case (name_momentum)
            node = model%graph%variable(size(model%coordinates) + parser%symbols%index(symbol))
        case (name_parameter)
            node = model%graph%parameter(parser%symbols%index(symbol))
        case default
            node = parser%symbols%index(symbol)
        end select
        call next_token(parser)
    end function parse_name

    !> function "(" expression { "," expression } ")"
    recursive integer function parse_call(parser, model, f) result(node)
        type(parser_t), intent(inout) :: parser
        type(model_definition_t), intent(inout) :: model
        integer, intent(in) :: f
        character(len=:), allocatable :: name
        integer :: arguments(3), count, line, column, op
        node = node_zero
        name = trim(functions(f))
        call token_position(parser, line, column)
        call next_token(parser)
        if (parser%failed) return
        if (.not. is_symbol(parser, "(")) then
            call fail_at(parser, line, column, "'" // name // "' is a function: write " // &
                name // "(...)")
            return
        end if
        call next_token(parser)
        if (parser%failed) return
        count = 0
        do
            if (count == size(arguments)) then
                call fail_at(parser, line, column, arity_text(name) // "; got more")
                return
            end if
            count = count + 1
            arguments(count) = parse_expression(parser, model)
            if (parser%failed) return
            if (.not. is_symbol(parser, ",")) exit
            call next_token(parser)
            if (parser%failed) return
        end do
        call expect_symbol(parser, ")", "',' or ')' in the arguments of " // name)
        if (parser%failed) return
        op = function_ops(f)
        if (op == op_atan .and. count == 2) op = op_atan2
        if ((op == op_atan2 .and. count /= 2) .or. (op /= op_atan2 .and. count /= 1)) then
            call fail_at(parser, line, column, arity_text(name) // "; got " // &
                int_str(count))
            return
        end if
        if (op == op_atan2) then
            node = model%graph%binary(op, arguments(1), arguments(2))
        else
            node = model%graph%unary(op, arguments(1))
        end if
        call model%graph%locate(node, line, column)
    end function parse_call

    !> "NAME takes 1 argument" etc.
    pure function arity_text(name) result(text)
        character(len=*), intent(in) :: name
        character(len=:), allocatable :: text
        select case (name)
        case ("atan2")
            text = "atan2 takes 2 arguments (y, x)"
        case ("atan")
            text = "atan takes 1 argument, or 2 (y, x) as atan2"
        case default
            text = name // " takes 1 argument"
        end select
    end function arity_text

    !> Index of a function name in `functions`, 0 if none.
    pure integer function function_index(name) result(f)
        character(len=*), intent(in) :: name
        integer :: k
        f = 0
        do k = 1, size(functions)
            if (trim(functions(k)) == name) f = k
        end do
    end function function_index

    !> Fail on an unknown name: used before its definition, or not defined at all.
    subroutine fail_unknown(parser, name)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: name
        integer :: later
        if (allocated(parser%defining)) then
            if (parser%defining == name) then
                call fail_token(parser, "'" // name // "' is used in its own definition")
                return
            end if
        end if
        later = declared_later(parser, name)
        if (later > 0) then
            call fail_token(parser, "'" // name // "' is used before its definition " // &
                "(line " // int_str(later) // "): define names before using them")
        else
            call fail_token(parser, "unknown name '" // name // "'" // &
                suggestion(name, [character(len=64) :: known_names(parser), functions, "pi"]))
        end if
    end subroutine fail_unknown

    !> The line of a later statement that declares `name`, 0 if none.
    integer function declared_later(parser, name) result(line)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: name
        integer :: k, saved, saved_position, saved_token, saved_start, saved_end
        character(len=:), allocatable :: keyword
        logical :: lists
        line = 0
        saved = parser%current
        saved_position = parser%position
        saved_token = parser%token
        saved_start = parser%token_start
        saved_end = parser%token_end
        do k = saved + 1, size(parser%statements)
            parser%current = k
            parser%position = 1
            call next_token(parser)
            if (parser%token /= tk_name) cycle
            keyword = lower(token_text(parser))
            lists = keyword == "coordinates" .or. keyword == "momenta"
            if (.not. (lists .or. keyword == "let" .or. keyword == "parameters" .or. &
                       keyword == "parameter")) cycle
            call next_token(parser)
            if (parser%failed) exit
            if (parser%token == tk_name) then
                if (token_text(parser) == name) line = parser%statements(k)%first_line
            end if
            do while (lists .and. parser%token /= tk_end .and. line == 0)
                if (parser%token == tk_name) then
                    if (token_text(parser) == name) line = parser%statements(k)%first_line
                end if
                call next_token(parser)
                if (parser%failed) exit
            end do
            if (line > 0) exit
        end do
        parser%failed = .false.
        parser%current = saved
        parser%position = saved_position
        parser%token = saved_token
        parser%token_start = saved_start
        parser%token_end = saved_end
    end function declared_later

    !> The names declared so far.
    function known_names(parser) result(names)
        type(parser_t), intent(in) :: parser
        character(len=64), allocatable :: names(:)
        integer :: k
        allocate (names(parser%symbols%count))
        do k = 1, parser%symbols%count
            names(k) = parser%symbols%names(k)%text
        end do
    end function known_names

    !> "; did you mean 'x'?" when a candidate is one edit away (or two for longer names).
    pure function suggestion(name, candidates) result(text)
        character(len=*), intent(in) :: name
        character(len=*), intent(in) :: candidates(:)
        character(len=:), allocatable :: text
        integer :: k, best, distance, best_distance
        text = ""
        if (len(name) < 2) return
        best = 0
        best_distance = 3
        do k = 1, size(candidates)
            distance = edit_distance(name, trim(candidates(k)))
            if (distance < best_distance .and. distance <= max(1, len(name) / 4)) then
                best = k
                best_distance = distance
            end if
        end do
        if (best > 0) text = " (did you mean '" // trim(candidates(best)) // "'?)"
    end function suggestion

    !> Levenshtein distance (names are short; longer texts count as far apart).
    pure integer function edit_distance(a, b) result(distance)
        character(len=*), intent(in) :: a, b
        integer :: row(0:len(b)), previous(0:len(b)), i, j
        if (len(a) > 64 .or. len(b) > 64) then
            distance = huge(0)
            return
        end if
        previous = [(j, j = 0, len(b))]
        do i = 1, len(a)
            row(0) = i
            do j = 1, len(b)
                row(j) = min(previous(j) + 1, row(j - 1) + 1, &
                             previous(j - 1) + merge(0, 1, a(i:i) == b(j:j)))
            end do
            previous = row
        end do
        distance = previous(len(b))
    end function edit_distance

    !> "coordinate 'x'" or "momentum 'px'" for variable i.
    function variable_name(model, i) result(text)
        type(model_definition_t), intent(in) :: model
        integer, intent(in) :: i
        character(len=:), allocatable :: text
        if (i <= size(model%coordinates)) then
            text = "coordinate '" // model%coordinates(i)%text // "'"
        else
            text = "momentum '" // model%momenta(i - size(model%coordinates))%text // "'"
        end if
    end function variable_name

    ! ------------------------------------------------------------------ names

    !> Append a name to a list.
    subroutine append_name(names, text)
        type(name_t), allocatable, intent(inout) :: names(:)
        character(len=*), intent(in) :: text
        type(name_t), allocatable :: longer(:)
        integer :: k
        allocate (longer(size(names) + 1))
        do k = 1, size(names)
            call move_alloc(names(k)%text, longer(k)%text)
        end do
        longer(size(longer))%text = text
        call move_alloc(longer, names)
    end subroutine append_name

    !> Declare a name of `kind` at the current token.
    subroutine declare(parser, name, kind, index)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: name
        integer, intent(in) :: kind, index
        integer :: line, column
        call token_position(parser, line, column)
        call declare_at(parser, name, kind, index, line, column)
    end subroutine declare

    !> Declare a name, refusing reserved words and names declared already.
    subroutine declare_at(parser, name, kind, index, line, column)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: name
        integer, intent(in) :: kind, index, line, column
        integer :: existing
        if (function_index(name) > 0 .or. name == "pi") then
            call fail_at(parser, line, column, "'" // name // "' is a function or constant " &
                // "of the grammar and cannot be declared")
            return
        end if
        if (any(keywords == name)) then
            call fail_at(parser, line, column, "'" // name // "' is a keyword and cannot be " &
                // "declared")
            return
        end if
        existing = find_symbol(parser%symbols, name)
        if (existing > 0) then
            call fail_at(parser, line, column, "'" // name // "' is declared twice (first " &
                // "as a " // kind_name(parser%symbols%kind(existing)) // ", at line " // &
                int_str(parser%symbols%line(existing)) // ")")
            return
        end if
        call add_symbol(parser%symbols, name, kind, index, line)
    end subroutine declare_at

    !> What a name kind is called.
    pure function kind_name(kind) result(text)
        integer, intent(in) :: kind
        character(len=:), allocatable :: text
        select case (kind)
        case (name_coordinate); text = "coordinate"
        case (name_momentum); text = "momentum"
        case (name_parameter); text = "parameter"
        case default; text = "let name"
        end select
    end function kind_name

    !> The line where `name` was declared (0 if it was not).
    integer function symbol_line(parser, name) result(line)
        type(parser_t), intent(in) :: parser
        character(len=*), intent(in) :: name
        integer :: symbol
        line = 0
        symbol = find_symbol(parser%symbols, name)
        if (symbol > 0) line = parser%symbols%line(symbol)
    end function symbol_line

    !> An empty symbol table.
    subroutine init_symbols(symbols)
        type(symbols_t), intent(out) :: symbols
        allocate (symbols%names(64), symbols%kind(64), symbols%index(64), symbols%line(64), &
                  symbols%table(256))
        symbols%table = 0
        symbols%count = 0
    end subroutine init_symbols

    !> Add a symbol (known to be new).
    subroutine add_symbol(symbols, name, kind, index, line)
        type(symbols_t), intent(inout) :: symbols
        character(len=*), intent(in) :: name
        integer, intent(in) :: kind, index, line
        integer :: k
        if (4 * (symbols%count + 1) > size(symbols%table)) call grow_symbols(symbols)
        symbols%count = symbols%count + 1
        k = symbols%count
        symbols%names(k)%text = name
        symbols%kind(k) = kind
        symbols%index(k) = index
        symbols%line(k) = line
        symbols%table(symbol_slot(symbols, name)) = k
    end subroutine add_symbol

    !> Double the symbol table.
    subroutine grow_symbols(symbols)
        type(symbols_t), intent(inout) :: symbols
        type(name_t), allocatable :: names(:)
        integer, allocatable :: kind(:), index(:), line(:)
        integer :: k, room
        room = 2 * size(symbols%names)
        allocate (names(room), kind(room), index(room), line(room))
        do k = 1, symbols%count
            call move_alloc(symbols%names(k)%text, names(k)%text)
        end do
        kind(:symbols%count) = symbols%kind(:symbols%count)
        index(:symbols%count) = symbols%index(:symbols%count)
        line(:symbols%count) = symbols%line(:symbols%count)
        call move_alloc(names, symbols%names)
        call move_alloc(kind, symbols%kind)
        call move_alloc(index, symbols%index)
        call move_alloc(line, symbols%line)
        deallocate (symbols%table)
        allocate (symbols%table(4 * room))
        symbols%table = 0
        do k = 1, symbols%count
            symbols%table(symbol_slot(symbols, symbols%names(k)%text)) = k
        end do
    end subroutine grow_symbols

    !> The symbol called `name`, 0 if none.
    integer function find_symbol(symbols, name) result(symbol)
        type(symbols_t), intent(in) :: symbols
        character(len=*), intent(in) :: name
        symbol = symbols%table(symbol_slot(symbols, name))
    end function find_symbol

    !> The table slot of `name`: where it is, or the empty slot where it goes.
    integer function symbol_slot(symbols, name) result(slot)
        type(symbols_t), intent(in) :: symbols
        character(len=*), intent(in) :: name
        integer :: h, k
        h = 7
        do k = 1, len(name)
            h = modulo(h * 31 + iachar(name(k:k)), 1000003)
        end do
        slot = modulo(h, size(symbols%table)) + 1
        do while (symbols%table(slot) /= 0)
            if (symbols%names(symbols%table(slot))%text == name) return
            slot = slot + 1
            if (slot > size(symbols%table)) slot = 1
        end do
    end function symbol_slot

    ! ------------------------------------------------------------------ tokens

    !> Read the next token of the current statement.
    subroutine next_token(parser)
        type(parser_t), intent(inout) :: parser
        character(len=:), allocatable :: text
        integer :: k, start
        character :: c
        associate (s => parser%statements(parser%current))
            text = s%text
        end associate
        k = parser%position
        do while (k <= len(text))
            if (text(k:k) /= " " .and. text(k:k) /= achar(9)) exit
            k = k + 1
        end do
        start = k
        parser%token_start = start
        if (k > len(text)) then
            parser%token = tk_end
            parser%token_end = k - 1
            parser%position = k
            return
        end if
        c = text(k:k)
        if (is_letter(c)) then
            do while (k <= len(text))
                if (.not. (is_letter(text(k:k)) .or. is_digit(text(k:k)) .or. &
                           text(k:k) == "_")) exit
                k = k + 1
            end do
            parser%token = tk_name
        else if (is_digit(c) .or. c == ".") then
            call scan_number(text, k)
            parser%token = tk_number
        else if (c == "*" .and. k < len(text)) then
            k = k + 1
            if (text(k:k) == "*") k = k + 1
            parser%token = tk_symbol
        else if (index("+-*/^(),=:", c) > 0) then
            k = k + 1
            parser%token = tk_symbol
        else
            parser%token_end = k
            parser%position = k + 1
            if (iachar(c) > 127) then
                call fail_token(parser, "unexpected byte " // int_str(iachar(c)) // &
                    " (names are ASCII letters, digits and '_')")
            else if (c == "\") then
                call fail_token(parser, "unexpected '\': it continues a statement only " // &
                    "at the end of a line")
            else
                call fail_token(parser, "unexpected character '" // c // "'")
            end if
            return
        end if
        parser%token_end = k - 1
        parser%position = k
    end subroutine next_token

    !> Advance k past a number: digits [. digits] [(e|E) [sign] digits].
    pure subroutine scan_number(text, k)
        character(len=*), intent(in) :: text
        integer, intent(inout) :: k
        integer :: mark
        do while (k <= len(text))
            if (.not. is_digit(text(k:k))) exit
            k = k + 1
        end do
        if (k <= len(text)) then
            if (text(k:k) == ".") then
                k = k + 1
                do while (k <= len(text))
                    if (.not. is_digit(text(k:k))) exit
                    k = k + 1
                end do
            end if
        end if
        if (k <= len(text)) then
            if (text(k:k) == "e" .or. text(k:k) == "E") then
                mark = k
                k = k + 1
                if (k <= len(text)) then
                    if (text(k:k) == "+" .or. text(k:k) == "-") k = k + 1
                end if
                if (k > len(text)) then
                    k = mark
                else if (.not. is_digit(text(k:k))) then
                    k = mark
                else
                    do while (k <= len(text))
                        if (.not. is_digit(text(k:k))) exit
                        k = k + 1
                    end do
                end if
            end if
        end if
        ! Letters glued to a number ("2x", "1.5e") make a malformed number, not two tokens.
        do while (k <= len(text))
            if (.not. (is_letter(text(k:k)) .or. is_digit(text(k:k)) .or. text(k:k) == "_" &
                       .or. text(k:k) == ".")) exit
            k = k + 1
        end do
    end subroutine scan_number

    elemental logical function is_letter(c)
        character, intent(in) :: c
        is_letter = (c >= "a" .and. c <= "z") .or. (c >= "A" .and. c <= "Z")
    end function is_letter

    elemental logical function is_digit(c)
        character, intent(in) :: c
        is_digit = c >= "0" .and. c <= "9"
    end function is_digit

    !> The text of the current token.
    function token_text(parser) result(text)
        type(parser_t), intent(in) :: parser
        character(len=:), allocatable :: text
        text = parser%statements(parser%current)%text(parser%token_start:parser%token_end)
    end function token_text

    !> Whether the current token is the symbol `symbol`.
    logical function is_symbol(parser, symbol)
        type(parser_t), intent(in) :: parser
        character(len=*), intent(in) :: symbol
        is_symbol = .false.
        if (parser%token == tk_symbol) is_symbol = token_text(parser) == symbol
    end function is_symbol

    !> Consume the symbol `symbol` or fail with "expected WHAT".
    subroutine expect_symbol(parser, symbol, what)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: symbol, what
        if (is_symbol(parser, symbol)) then
            call next_token(parser)
        else
            call fail_token(parser, "expected " // what)
        end if
    end subroutine expect_symbol

    !> Fail unless the current token is a name.
    subroutine expect_name(parser, what)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: what
        if (parser%token /= tk_name) call fail_token(parser, "expected " // trim(what))
    end subroutine expect_name

    !> Line and column of the current token.
    subroutine token_position(parser, line, column)
        type(parser_t), intent(in) :: parser
        integer, intent(out) :: line, column
        call text_position(parser, parser%token_start, line, column)
    end subroutine token_position

    !> Line and column of character k of the current statement (past its end: the column
    !! after its last character).
    subroutine text_position(parser, k, line, column)
        type(parser_t), intent(in) :: parser
        integer, intent(in) :: k
        integer, intent(out) :: line, column
        integer :: last
        associate (s => parser%statements(parser%current))
            last = len_trim(s%text)
            if (k <= last .and. k >= 1) then
                line = s%line(k)
                column = s%column(k)
            else if (last >= 1) then
                line = s%line(last)
                column = s%column(last) + 1
            else
                line = s%first_line
                column = 1
            end if
        end associate
    end subroutine text_position

    ! ------------------------------------------------------------------ failures

    !> Fail at the current token: "LINE:COLUMN: MESSAGE; got 'TOKEN'" (or "got the end of
    !! the line").
    subroutine fail_token(parser, message)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: message
        integer :: line, column
        character(len=:), allocatable :: got
        if (parser%failed) return
        call token_position(parser, line, column)
        if (parser%token == tk_end) then
            got = "; got the end of the line"
        else if (index(message, "'" // token_text(parser) // "'") > 0 .or. &
                 parser%token_end - parser%token_start > 40) then
            got = ""
        else
            got = "; got '" // token_text(parser) // "'"
        end if
        call fail_at(parser, line, column, message // got)
    end subroutine fail_token

    !> Fail at the first character of the current statement (its keyword).
    subroutine fail_at_statement(parser, message)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: message
        integer :: line, column
        call text_position(parser, max(1, verify(parser%statements(parser%current)%text, &
                                                 " " // achar(9))), line, column)
        call fail_at(parser, line, column, message)
    end subroutine fail_at_statement

    !> Fail at a line and column.
    subroutine fail_at(parser, line, column, message)
        type(parser_t), intent(inout) :: parser
        integer, intent(in) :: line, column
        character(len=*), intent(in) :: message
        if (parser%failed) return
        parser%failed = .true.
        parser%message = int_str(line) // ":" // int_str(column) // ": " // message
    end subroutine fail_at

    !> Fail for the model as a whole (no position).
    subroutine fail_model(parser, message)
        type(parser_t), intent(inout) :: parser
        character(len=*), intent(in) :: message
        if (parser%failed) return
        parser%failed = .true.
        parser%message = " " // message
    end subroutine fail_model

end module holosym_model_parser
