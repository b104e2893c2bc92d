!> category: internal module (use holosym)
!! A system given by formulas: `formula_model` extends `constrained_hamiltonian` with
!! everything derived from the model's text, nothing declared by hand.
!!
!! `load_model(file, model, status)` or `model_from_text(text, model, status)` reads the
!! model (holosym_model_parser), differentiates it symbolically (holosym_expression: the
!! gradients of H, the Jacobian of the constraints, the second derivatives of both) and
!! compiles every binding to a tape (holosym_tape), evaluated in working precision and,
!! for the reduced step's first iterations, in real64. The graph also gives the
!! structure: the sparsity of Phi and of the Hessian of U, and whether H = sum_i p_i^2 /
!! (2 m_i) + U(q) with constant m_i, in which case `diagonal_mass` declares the masses and
!! the integrator takes the reduced step. Parameters keep their names and can be set
!! after loading (`set_parameter`; before `init` of an integrator, which takes the masses
!! then).
!!
!! A model with an initial state is refused at load when the state cannot be used: H, its
!! gradients, the constraints or their Jacobian not finite there (the message names the
!! operation and where it is written), dependent constraints, or a state too far from
!! the constraint manifold to project. `initial_state` evaluates the initial values with
!! the current parameters, turns velocities into momenta (`state_from_velocities`) and
!! projects a state off the manifold, saying so in its `note`.
module holosym_formula_model
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_MODEL, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_SIZE_MISMATCH
    use holosym_text_file, only: text_line_t, read_text_lines
    use holosym_problem, only: constrained_hamiltonian
    use holosym_manifold, only: manifold_residuals, full_rank_constraints, &
        sparse_full_rank_constraints, manifold_tolerance_default
    use holosym_projection, only: project_to_manifold, projection_report_t
    use holosym_initial_states, only: state_from_velocities
    use holosym_expression, only: expression_graph_t, node_zero, operation_name, &
        failure_text, op_constant
    use holosym_tape, only: tape_t, rounded
    use holosym_model_parser, only: model_definition_t, name_t, parse_model, split_text
    implicit none
    private

    public :: formula_model, load_model, model_from_text

    !> Entries of Phi up to which the rank test at load forms Phi Phi^T densely (m^2 n
    !! operations); beyond, the Gram matrix is factored in band storage along the
    !! constraints' order (linear in m for chain-like systems).
    integer(int64), parameter :: dense_rank_limit = 4096

    !> A list of integers that grows by doubling.
    type :: int_list_t
        integer, allocatable :: items(:)
        integer :: count = 0
    end type int_list_t

    !> A system read from a model file (see the module).
    type, extends(constrained_hamiltonian) :: formula_model
        !> The model as written: names, expressions, initial state.
        type(model_definition_t), private :: definition
        !> Current parameter values (working precision and rounded) and which were set.
        real(wp), allocatable, private :: values(:)
        real(dp), allocatable, private :: values_dp(:)
        logical, allocatable, private :: assigned(:)
        !> The compiled bindings.
        type(tape_t), private :: h_tape, hq_tape, hp_tape, phi_tape, jac_tape, hess_tape, &
            phi_hess_tape, mass_tape, initial_tape, event_tape
        !> Pattern of Phi (constraint, coordinate), in the order of `jac_tape`'s outputs.
        integer, allocatable, private :: jac_rows(:), jac_cols(:)
        !> Entries of the Hessian of H (variables 1..2n, first <= second).
        integer, allocatable, private :: hess_first(:), hess_second(:)
        !> Entries of the constraints' Hessians: constraint, coordinates (first <= second).
        integer, allocatable, private :: phi_hess_l(:), phi_hess_first(:), phi_hess_second(:)
        !> Pattern of the Hessian of U (first <= second), for `potential_sparsity`.
        integer, allocatable, private :: u_first(:), u_second(:)
        !> H = sum_i p_i^2 / (2 m_i) + U(q) with constant m_i (from the graph).
        logical, private :: separable = .false.
        !> A digest of the model's text (hexadecimal).
        character(len=16), private :: digest = ""
        !> The model's text, line by line (for `extended`).
        type(text_line_t), allocatable, private :: lines(:)
    contains
        procedure :: hamiltonian => model_hamiltonian
        procedure :: dh_dq => model_dh_dq
        procedure :: dh_dp => model_dh_dp
        procedure :: constraint => model_constraint
        procedure :: constraint_jacobian => model_constraint_jacobian
        !> Exact second derivatives of H, from the graph.
        procedure :: hessian => model_hessian
        !> Exact second derivatives of the constraints, from the graph.
        procedure :: constraint_hessian => model_constraint_hessian
        !> The masses when H has the separable form (found in the graph).
        procedure :: diagonal_mass => model_diagonal_mass
        !> The nonzero pattern of Phi, from the graph.
        procedure :: constraint_sparsity => model_constraint_sparsity
        !> Phi at its pattern.
        procedure :: constraint_jacobian_values => model_constraint_values
        !> The nonzero pattern of the Hessian of U, from the graph.
        procedure :: potential_sparsity => model_potential_sparsity
        !> dH/dq evaluated in real64.
        procedure :: dh_dq_double => model_dh_dq_double
        !> The same at many points in one pass of each tape (vectorized across the points).
        procedure :: dh_dq_points => model_dh_dq_points
        procedure :: dh_dp_points => model_dh_dp_points
        procedure :: dh_dq_double_points => model_dh_dq_double_points
        procedure :: constraint_points => model_constraint_points
        procedure :: constraint_jacobian_values_points => model_constraint_values_points
        !> Set a parameter by name.
        procedure :: set_parameter => model_set_parameter
        !> The value of a parameter by name.
        procedure :: get_parameter => model_get_parameter
        !> Number of parameters, and the name of parameter k.
        procedure :: parameter_count => model_parameter_count
        procedure :: parameter_name => model_parameter_name
        !> Names of coordinate and momentum i.
        procedure :: coordinate_name => model_coordinate_name
        procedure :: momentum_name => model_momentum_name
        !> Whether the model states an initial state.
        procedure :: has_initial_state => model_has_initial_state
        !> The initial state with the current parameters, on the manifold.
        procedure :: initial_state => model_initial_state
        !> Where the model came from (file name, or the name given to the text).
        procedure :: source => model_source
        !> Instructions of the compiled bindings (H, dH/dq, dH/dp, phi, Phi, Hessians).
        procedure :: tape_lengths => model_tape_lengths
        !> Whether H was found to have the separable form (masses constant).
        procedure :: is_separable => model_is_separable
        !> A digest of the model's text, to tell two versions of a file apart.
        procedure :: text_digest => model_text_digest
        !> The model's `event` statements: how many, the name, direction (-1, 0, 1) and
        !! `stop` of event k, and the values of all at a state (`holosym_events` turns
        !! them into an `event_set`: `model_events`).
        procedure :: event_count => model_event_count
        procedure :: event_name => model_event_name
        procedure :: event_direction => model_event_direction
        procedure :: event_stops => model_event_stops
        procedure :: event_values => model_event_values
        !> This model with more statements after its own (e.g. an `event` over its names).
        procedure :: extended => model_extended
        !> Lines of the model's text (those of `extended`'s statements follow).
        procedure :: line_count => model_line_count
    end type formula_model

contains

    ! ------------------------------------------------------------------ loading

    !> Read a model file. On failure `status` has code HOLOSYM_INVALID_MODEL and a message
    !! "FILE:LINE:COLUMN: what is wrong" (or "FILE: ..." for the file as a whole), and
    !! `model` is empty.
    subroutine load_model(file, model, status)
        character(len=*), intent(in) :: file          !! the model file
        type(formula_model), intent(out) :: model     !! the model
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: message
        type(holosym_status_t) :: local
        integer :: ios
        call read_text_lines(file, lines, ios, message)
        if (ios /= 0) then
            call set_status(local, HOLOSYM_INVALID_MODEL, file // ": " // message)
        else
            call build_model(lines, file, model, local)
        end if
        call report(local, status)
    end subroutine load_model

    !> A model from its text (lines separated by line feeds); `name` stands for the file in
    !! messages (default "model"). Failures as for `load_model`.
    subroutine model_from_text(text, model, status, name)
        character(len=*), intent(in) :: text          !! the model
        type(formula_model), intent(out) :: model     !! the model
        type(holosym_status_t), intent(out), optional :: status !! outcome
        character(len=*), intent(in), optional :: name !! name for messages
        type(text_line_t), allocatable :: lines(:)
        type(holosym_status_t) :: local
        call split_text(text, lines)
        if (present(name)) then
            call build_model(lines, name, model, local)
        else
            call build_model(lines, "model", model, local)
        end if
        call report(local, status)
    end subroutine model_from_text

    !> This model with the statements of `text` (lines separated by line feeds) read after
    !! its own, and the parameters set by name carried over: the same system, with e.g. an
    !! `event` statement over the model's names added. Failures as for `model_from_text`
    !! (the lines of `text` numbered after the model's); `extended` is then empty.
    subroutine model_extended(self, text, extended, status)
        class(formula_model), intent(in) :: self       !! the model
        character(len=*), intent(in) :: text           !! the statements to add
        type(formula_model), intent(out) :: extended   !! the model with them
        type(holosym_status_t), intent(out) :: status  !! outcome
        type(text_line_t), allocatable :: more(:)
        integer :: k
        call split_text(text, more)
        call build_model([self%lines, more], self%source(), extended, status)
        if (.not. status%ok()) return
        do k = 1, size(self%assigned)
            if (.not. self%assigned(k)) cycle
            call extended%set_parameter(self%definition%parameters(k)%text, self%values(k), &
                                        status)
            if (.not. status%ok()) return
        end do
    end subroutine model_extended

    !> Lines of the model's text.
    pure integer function model_line_count(self) result(lines)
        class(formula_model), intent(in) :: self
        lines = 0
        if (allocated(self%lines)) lines = size(self%lines)
    end function model_line_count

    !> Return `local` through `status`, or stop with its message when `status` is absent.
    subroutine report(local, status)
        type(holosym_status_t), intent(in) :: local
        type(holosym_status_t), intent(out), optional :: status
        if (present(status)) then
            status = local
        else if (.not. local%ok()) then
            error stop local%message
        end if
    end subroutine report

    !> Parse, derive, compile and check a model.
    subroutine build_model(lines, source, model, status)
        type(text_line_t), intent(in) :: lines(:)
        character(len=*), intent(in) :: source
        type(formula_model), intent(inout) :: model
        type(holosym_status_t), intent(out) :: status
        logical :: ok
        character(len=:), allocatable :: message
        call parse_model(lines, source, model%definition, ok, message)
        if (.not. ok) then
            call set_status(status, HOLOSYM_INVALID_MODEL, message)
            return
        end if
        model%n = size(model%definition%coordinates)
        model%m = size(model%definition%constraints)
        model%digest = text_digest(lines)
        model%lines = lines
        allocate (model%assigned(size(model%definition%parameters)))
        model%assigned = .false.
        call evaluate_parameters(model, status)
        if (.not. status%ok()) return
        call derive(model)
        if (model%definition%has_initial) call check_initial_state(model, status)
        if (.not. status%ok()) return
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine build_model

    !> The parameter values from their definitions (those set by name kept).
    subroutine evaluate_parameters(model, status)
        type(formula_model), intent(inout) :: model
        type(holosym_status_t), intent(out) :: status
        real(wp), allocatable :: nodes(:)
        integer :: k, failed, failure
        real(wp) :: none(0)
        associate (d => model%definition)
            if (.not. allocated(model%values)) then
                allocate (model%values(size(d%parameters)))
                model%values = 0
            end if
            do k = 1, size(d%parameters)
                if (model%assigned(k)) cycle
                call d%graph%evaluate_safely([d%parameter_definitions(k)], none, &
                                             model%values, nodes, failed, failure)
                if (failed /= 0) then
                    call set_status(status, HOLOSYM_INVALID_MODEL, where_text(model, failed) // &
                        "the value of parameter '" // d%parameters(k)%text // &
                        "' cannot be computed: " // what_failed(model, failed, failure))
                    return
                end if
                model%values(k) = nodes(d%parameter_definitions(k))
            end do
        end associate
        model%values_dp = rounded(model%values)
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine evaluate_parameters


    ! ------------------------------------------------------------------ derivation

    !> Differentiate, find the structure, compile the tapes.
    subroutine derive(model)
        type(formula_model), intent(inout) :: model
        integer, allocatable :: first(:), jac(:), hess(:), phi_hess(:), initial(:)
        integer :: n, m
        n = model%n
        m = model%m
        associate (g => model%definition%graph, d => model%definition)
            allocate (first(2 * n))
            call g%gradient(d%hamiltonian, 2 * n, first)
            call model%h_tape%build(g, [d%hamiltonian], n)
            call model%hq_tape%build(g, first(1:n), n)
            call model%hp_tape%build(g, first(n + 1:2 * n), n)
            call model%phi_tape%build(g, d%constraints, n)
            call jacobian_entries(model, jac)
            call model%jac_tape%build(g, jac, n)
            call hamiltonian_hessian(model, first, hess)
            call model%hess_tape%build(g, hess, n)
            call constraint_hessians(model, jac, phi_hess)
            call model%phi_hess_tape%build(g, phi_hess, n)
            call find_structure(model, hess)
            initial = [integer ::]
            if (d%has_initial) then
                initial = [d%initial_q, d%initial_p]
                where (initial == 0) initial = node_zero
            end if
            call model%initial_tape%build(g, initial, n)
            call model%event_tape%build(g, d%events, n)
        end associate
    end subroutine derive

    !> The nonzero entries of Phi (row by row) and their nodes.
    subroutine jacobian_entries(model, nodes)
        type(formula_model), intent(inout) :: model
        integer, allocatable, intent(out) :: nodes(:)
        integer :: l, i, row(model%n)
        type(int_list_t) :: rows, cols, found
        associate (g => model%definition%graph, d => model%definition)
            do l = 1, model%m
                call g%gradient(d%constraints(l), model%n, row)
                do i = 1, model%n
                    if (row(i) == node_zero) cycle
                    call push(rows, l)
                    call push(cols, i)
                    call push(found, row(i))
                end do
            end do
        end associate
        model%jac_rows = items(rows)
        model%jac_cols = items(cols)
        nodes = items(found)
    end subroutine jacobian_entries

    !> The nonzero second derivatives of H over (q, p) (first <= second), from the
    !! gradients of its first derivatives `first`.
    subroutine hamiltonian_hessian(model, first, nodes)
        type(formula_model), intent(inout) :: model
        integer, intent(in) :: first(:)
        integer, allocatable, intent(out) :: nodes(:)
        integer :: i, k, row(2 * model%n)
        type(int_list_t) :: a, b, found
        associate (g => model%definition%graph)
            do i = 1, 2 * model%n
                call g%gradient(first(i), 2 * model%n, row)
                do k = i, 2 * model%n
                    if (row(k) == node_zero) cycle
                    call push(a, i)
                    call push(b, k)
                    call push(found, row(k))
                end do
            end do
        end associate
        model%hess_first = items(a)
        model%hess_second = items(b)
        nodes = items(found)
    end subroutine hamiltonian_hessian

    !> The nonzero second derivatives of each constraint (first <= second), from the
    !! gradients of the entries of Phi.
    subroutine constraint_hessians(model, jac, nodes)
        type(formula_model), intent(inout) :: model
        integer, intent(in) :: jac(:)
        integer, allocatable, intent(out) :: nodes(:)
        integer :: e, k, row(model%n)
        type(int_list_t) :: l, a, b, found
        associate (g => model%definition%graph)
            do e = 1, size(jac)
                call g%gradient(jac(e), model%n, row)
                do k = model%jac_cols(e), model%n
                    if (row(k) == node_zero) cycle
                    call push(l, model%jac_rows(e))
                    call push(a, model%jac_cols(e))
                    call push(b, k)
                    call push(found, row(k))
                end do
            end do
        end associate
        model%phi_hess_l = items(l)
        model%phi_hess_first = items(a)
        model%phi_hess_second = items(b)
        nodes = items(found)
    end subroutine constraint_hessians

    !> H = sum_i p_i^2 / (2 m_i) + U(q) with constant m_i exactly when no second
    !! derivative mixes q and p and those in p are d2H/dp_i^2 alone, each independent of the
    !! variables (dH/dp_i = p_i / m_i + b_i; b_i = 0 is checked with the values, in
    !! `diagonal_mass`). The pattern of the Hessian of U is the q-q block.
    subroutine find_structure(model, hess)
        type(formula_model), intent(inout) :: model
        integer, intent(in) :: hess(:)
        integer :: n, e
        integer, allocatable :: masses(:)
        logical :: qq, qp, pp
        n = model%n
        allocate (masses(n))
        masses = 0
        model%separable = .true.
        do e = 1, size(hess)
            qq = model%hess_second(e) <= n
            pp = model%hess_first(e) > n
            qp = .not. (qq .or. pp)
            if (qp) then
                model%separable = .false.
            else if (pp) then
                if (model%hess_first(e) /= model%hess_second(e) .or. &
                    model%definition%graph%varying(hess(e))) then
                    model%separable = .false.
                else
                    masses(model%hess_first(e) - n) = hess(e)
                end if
            end if
        end do
        if (any(masses == 0)) model%separable = .false.
        qq_pattern: block
            logical, allocatable :: in_u(:)
            in_u = model%hess_second <= n
            model%u_first = pack(model%hess_first, in_u)
            model%u_second = pack(model%hess_second, in_u)
        end block qq_pattern
        if (model%separable) then
            call model%mass_tape%build(model%definition%graph, masses, n)
        else
            call model%mass_tape%build(model%definition%graph, [integer ::], n)
        end if
    end subroutine find_structure

    !> Append to a list.
    subroutine push(list, item)
        type(int_list_t), intent(inout) :: list
        integer, intent(in) :: item
        integer, allocatable :: larger(:)
        if (.not. allocated(list%items)) allocate (list%items(64))
        if (list%count == size(list%items)) then
            allocate (larger(2 * list%count))
            larger(:list%count) = list%items
            call move_alloc(larger, list%items)
        end if
        list%count = list%count + 1
        list%items(list%count) = item
    end subroutine push

    !> The items of a list.
    pure function items(list) result(out)
        type(int_list_t), intent(in) :: list
        integer :: out(list%count)
        if (list%count > 0) out = list%items(:list%count)
    end function items

    ! ------------------------------------------------------------------ initial state

    !> At load: the initial state must be computable, the model finite there, the
    !! constraints independent, and the projection must succeed.
    subroutine check_initial_state(model, status)
        type(formula_model), intent(inout) :: model
        type(holosym_status_t), intent(out) :: status
        real(wp) :: q(model%n), p(model%n)
        character(len=:), allocatable :: note
        call evaluate_initial(model, q, p, status)
        if (.not. status%ok()) return
        if (.not. model%definition%velocities) then
            call check_finite(model, q, p, status)
            if (.not. status%ok()) return
        else
            call check_finite(model, q, 0 * p, status)
            if (.not. status%ok()) return
        end if
        call check_rank(model, q, status)
        if (.not. status%ok()) return
        call model%initial_state(q, p, status, note)
        if (.not. status%ok()) then
            call set_status(status, HOLOSYM_INVALID_MODEL, model%definition%source // ":" // &
                int_str(model%definition%initial_line) // ": the initial state cannot be " // &
                "brought onto the constraint manifold: " // status%message)
            return
        end if
        call check_finite(model, q, p, status)
    end subroutine check_initial_state

    !> The initial values with every operation checked (at load, and where parameters
    !! changed): all in one pass; on a failure, the value that fails is found and named.
    subroutine evaluate_initial(model, q, p, status)
        type(formula_model), intent(inout) :: model
        real(wp), intent(out) :: q(:), p(:)
        type(holosym_status_t), intent(out) :: status
        real(wp), allocatable :: nodes(:)
        real(wp) :: none(0)
        integer :: k, failed, failure, n
        integer, allocatable :: roots(:)
        n = model%n
        associate (d => model%definition)
            roots = [d%initial_q, d%initial_p]
            where (roots == 0) roots = node_zero
            call d%graph%evaluate_safely(roots, none, model%values, nodes, failed, failure)
            if (failed /= 0) then
                do k = 1, 2 * n
                    call d%graph%evaluate_safely(roots(k:k), none, model%values, nodes, &
                                                 failed, failure)
                    if (failed /= 0) exit
                end do
                call set_status(status, HOLOSYM_INVALID_MODEL, where_text(model, failed, &
                    d%initial_line) // initial_name(k) // " cannot be computed: " // &
                    what_failed(model, failed, failure))
                return
            end if
            q = nodes(roots(1:n))
            p = nodes(roots(n + 1:2 * n))
        end associate
        call set_status(status, HOLOSYM_SUCCESS, "")
    contains
        function initial_name(k) result(text)
            integer, intent(in) :: k
            character(len=:), allocatable :: text
            if (k <= n) then
                text = "the initial value of '" // model%definition%coordinates(k)%text // "'"
            else if (model%definition%velocities) then
                text = "the initial velocity of '" // &
                    model%definition%coordinates(k - n)%text // "'"
            else
                text = "the initial value of '" // model%definition%momenta(k - n)%text // "'"
            end if
        end function initial_name
    end subroutine evaluate_initial

    !> H, its gradients, the constraints and their Jacobian at (q, p), every operation
    !! checked: the first that fails is named, with where it is written.
    subroutine check_finite(model, q, p, status)
        type(formula_model), intent(inout) :: model
        real(wp), intent(in) :: q(:), p(:)
        type(holosym_status_t), intent(out) :: status
        real(wp), allocatable :: nodes(:)
        integer :: failed, failure, l, n
        integer, allocatable :: first(:), row(:)
        n = model%n
        associate (d => model%definition, g => model%definition%graph)
            call g%evaluate_safely([d%hamiltonian], [q, p], model%values, nodes, failed, &
                                   failure)
            if (failed /= 0) then
                call fail("H", d%hamiltonian_line)
                return
            end if
            do l = 1, model%m
                call g%evaluate_safely([d%constraints(l)], [q, p], model%values, nodes, &
                                       failed, failure)
                if (failed /= 0) then
                    call fail("constraint " // int_str(l), d%constraint_lines(l))
                    return
                end if
                allocate (row(n))
                call g%gradient(d%constraints(l), n, row)
                call g%evaluate_safely(row, [q, p], model%values, nodes, failed, failure)
                deallocate (row)
                if (failed /= 0) then
                    call fail("the derivative of constraint " // int_str(l), &
                              d%constraint_lines(l))
                    return
                end if
            end do
            allocate (first(2 * n))
            call g%gradient(d%hamiltonian, 2 * n, first)
            call g%evaluate_safely(first, [q, p], model%values, nodes, failed, failure)
            if (failed /= 0) then
                call fail("the gradient of H", d%hamiltonian_line)
                return
            end if
        end associate
        call set_status(status, HOLOSYM_SUCCESS, "")
    contains
        subroutine fail(what, line)
            character(len=*), intent(in) :: what
            integer, intent(in) :: line
            call set_status(status, HOLOSYM_INVALID_MODEL, where_text(model, failed, line) // &
                what // " is not finite at the initial state: " // &
                what_failed(model, failed, failure))
        end subroutine fail
    end subroutine check_finite

    !> The constraints must be independent at the initial positions.
    subroutine check_rank(model, q, status)
        type(formula_model), intent(inout) :: model
        real(wp), intent(in) :: q(:)
        type(holosym_status_t), intent(out) :: status
        character(len=:), allocatable :: message
        logical :: full_rank
        integer :: l
        call set_status(status, HOLOSYM_SUCCESS, "")
        if (model%m == 0) return
        if (int(model%m, int64) * model%n <= dense_rank_limit) then
            full_rank = full_rank_constraints(model, q, message)
        else
            full_rank = sparse_full_rank_constraints(model, model%jac_rows, model%jac_cols, &
                [(l, l = 1, model%m)], q, message)
        end if
        if (.not. full_rank) call set_status(status, HOLOSYM_INVALID_MODEL, &
            model%definition%source // ":" // int_str(model%definition%initial_line) // &
            ": the constraints are dependent at the initial state: " // message)
    end subroutine check_rank

    !> "SOURCE:LINE:COLUMN: " of a node written in the text (else of `line`, else "SOURCE: ").
    function where_text(model, node, line) result(text)
        type(formula_model), intent(in) :: model
        integer, intent(in) :: node
        integer, intent(in), optional :: line
        character(len=:), allocatable :: text
        associate (g => model%definition%graph)
            if (g%line(node) > 0) then
                text = model%definition%source // ":" // int_str(g%line(node)) // ":" // &
                    int_str(g%column(node)) // ": "
            else if (present(line)) then
                text = model%definition%source // ":" // int_str(line) // ": "
            else
                text = model%definition%source // ": "
            end if
        end associate
    end function where_text

    !> "log: argument outside the domain" etc. for the failing node.
    function what_failed(model, node, failure) result(text)
        type(formula_model), intent(in) :: model
        integer, intent(in) :: node, failure
        character(len=:), allocatable :: text
        associate (g => model%definition%graph)
            if (g%op(node) == op_constant) then
                text = failure_text(failure)
            else
                text = operation_name(g%op(node)) // ": " // failure_text(failure)
            end if
            if (g%line(node) == 0) text = text // " (in a derivative)"
        end associate
    end function what_failed

    !> The initial state with the current parameters: the model's initial values,
    !! velocities turned into momenta, projected onto the constraint manifold when off it.
    !! `note` says what was done ("" when the state was used as written). Codes:
    !! HOLOSYM_INVALID_ARGUMENT (the model states no initial state), HOLOSYM_SIZE_MISMATCH
    !! (q, p not of size n), HOLOSYM_INVALID_MODEL (an initial value cannot be computed),
    !! and those of `state_from_velocities` and `project_to_manifold`. On failure q and p
    !! are unchanged.
    subroutine model_initial_state(self, q, p, status, note)
        class(formula_model), intent(inout) :: self
        real(wp), intent(inout) :: q(:)  !! coordinates (n)
        real(wp), intent(inout) :: p(:)  !! momenta (n)
        type(holosym_status_t), intent(out), optional :: status !! outcome
        character(len=:), allocatable, intent(out), optional :: note !! what was done
        type(holosym_status_t) :: local
        type(projection_report_t) :: projection
        real(wp) :: q0(self%n), p0(self%n), v0(self%n), position, velocity, scaled_q, scaled_p
        character(len=:), allocatable :: done
        done = ""
        if (.not. self%definition%has_initial) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, self%definition%source // &
                ": the model states no initial state (an 'initial' statement)")
        else if (size(q) /= self%n .or. size(p) /= self%n) then
            call set_status(local, HOLOSYM_SIZE_MISMATCH, "initial_state: q and p must " // &
                "have size n = " // int_str(self%n))
        else
            call evaluate_initial(self, q0, p0, local)
        end if
        if (local%ok()) then
            if (self%definition%velocities) then
                v0 = p0
                call tangency(self, q0, v0, position, velocity, scaled_q, scaled_p)
                call state_from_velocities(self, q0, v0, p0, local, report=projection)
                if (local%ok() .and. scaled_q > manifold_tolerance_default) done = &
                    "the initial positions are off the constraints by " // &
                    real_str(position) // "; projected (moved by " // &
                    real_str(projection%position_shift) // ")"
                if (local%ok() .and. scaled_p > manifold_tolerance_default) then
                    if (len(done) > 0) done = done // "; "
                    done = done // "the initial velocities are not tangent to the " // &
                        "constraints (|Phi v| = " // real_str(velocity) // "); their normal " // &
                        "part removed"
                end if
            else
                call manifold_residuals(self, q0, p0, position, velocity, scaled_q, scaled_p)
                if (scaled_q > manifold_tolerance_default .or. &
                    scaled_p > manifold_tolerance_default) then
                    call project_to_manifold(self, q0, p0, local, report=projection)
                    if (local%ok()) done = "the initial state is off the constraint " // &
                        "manifold (|phi| = " // real_str(position) // ", |Phi H_p| = " // &
                        real_str(velocity) // "); projected (q moved by " // &
                        real_str(projection%position_shift) // ", p by " // &
                        real_str(projection%momentum_shift) // ")"
                end if
            end if
        end if
        if (local%ok()) then
            q = q0
            p = p0
        end if
        if (present(note)) note = done
        call report(local, status)
    end subroutine model_initial_state

    !> Residuals of positions q and velocities v: max |phi(q)| and max |Phi(q) v|, and
    !! both scaled as `manifold_residuals` scales them.
    subroutine tangency(self, q, v, position, velocity, scaled_q, scaled_v)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:), v(:)
        real(wp), intent(out) :: position, velocity, scaled_q, scaled_v
        real(wp) :: phi(self%m), jac(self%m, self%n), hidden(self%m)
        integer :: l
        position = 0
        velocity = 0
        scaled_q = 0
        scaled_v = 0
        if (self%m == 0) return
        call self%constraint(q, phi)
        call self%constraint_jacobian(q, jac)
        hidden = matmul(jac, v)
        position = maxval(abs(phi))
        velocity = maxval(abs(hidden))
        do l = 1, self%m
            scaled_q = max(scaled_q, abs(phi(l)) / (1 + maxval(abs(q)) * maxval(abs(jac(l, :)))))
            scaled_v = max(scaled_v, abs(hidden(l)) / (1 + sum(abs(jac(l, :)) * abs(v))))
        end do
    end subroutine tangency

    ! ------------------------------------------------------------------ parameters

    !> Set parameter `name` to `value` (finite); parameters defined from it follow unless
    !! set themselves. Codes: HOLOSYM_INVALID_ARGUMENT (no such parameter, value not
    !! finite, or a parameter defined from it cannot be computed: the model is then
    !! unchanged).
    subroutine model_set_parameter(self, name, value, status)
        class(formula_model), intent(inout) :: self
        character(len=*), intent(in) :: name  !! the parameter
        real(wp), intent(in) :: value         !! its new value
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        real(wp), allocatable :: saved(:)
        logical, allocatable :: saved_assigned(:)
        integer :: k
        k = parameter_index(self, name)
        if (k == 0) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "the model has no parameter '" &
                // name // "'" // parameter_list(self))
        else if (.not. is_finite(value)) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "parameter '" // name // &
                "': the value must be finite")
        else
            saved = self%values
            saved_assigned = self%assigned
            self%values(k) = value
            self%assigned(k) = .true.
            call evaluate_parameters(self, local)
            if (.not. local%ok()) then
                self%values = saved
                self%assigned = saved_assigned
                self%values_dp = rounded(saved)
                local%code = HOLOSYM_INVALID_ARGUMENT
            end if
        end if
        call report(local, status)
    end subroutine model_set_parameter

    !> The value of parameter `name`. Codes: HOLOSYM_INVALID_ARGUMENT (no such parameter;
    !! value is then 0).
    subroutine model_get_parameter(self, name, value, status)
        class(formula_model), intent(in) :: self
        character(len=*), intent(in) :: name  !! the parameter
        real(wp), intent(out) :: value        !! its value
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        integer :: k
        value = 0
        k = parameter_index(self, name)
        if (k == 0) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "the model has no parameter '" &
                // name // "'" // parameter_list(self))
        else
            value = self%values(k)
            call set_status(local, HOLOSYM_SUCCESS, "")
        end if
        call report(local, status)
    end subroutine model_get_parameter

    !> Index of parameter `name`, 0 if none.
    pure integer function parameter_index(self, name) result(k)
        class(formula_model), intent(in) :: self
        character(len=*), intent(in) :: name
        integer :: j
        k = 0
        if (.not. allocated(self%definition%parameters)) return
        do j = 1, size(self%definition%parameters)
            if (self%definition%parameters(j)%text == name) k = j
        end do
    end function parameter_index

    !> " (its parameters: a, b)" or " (it has none)".
    function parameter_list(self) result(text)
        class(formula_model), intent(in) :: self
        character(len=:), allocatable :: text
        integer :: k
        if (self%parameter_count() == 0) then
            text = " (it has none)"
            return
        end if
        text = " (its parameters: "
        do k = 1, self%parameter_count()
            if (k > 1) text = text // ", "
            text = text // self%parameter_name(k)
        end do
        text = text // ")"
    end function parameter_list

    !> Number of parameters.
    pure integer function model_parameter_count(self) result(count)
        class(formula_model), intent(in) :: self
        count = 0
        if (allocated(self%definition%parameters)) count = size(self%definition%parameters)
    end function model_parameter_count

    !> Name of parameter k (1..parameter_count).
    function model_parameter_name(self, k) result(name)
        class(formula_model), intent(in) :: self
        integer, intent(in) :: k !! the parameter's index
        character(len=:), allocatable :: name
        name = self%definition%parameters(k)%text
    end function model_parameter_name

    !> Name of coordinate i (1..n).
    function model_coordinate_name(self, i) result(name)
        class(formula_model), intent(in) :: self
        integer, intent(in) :: i !! the coordinate's index
        character(len=:), allocatable :: name
        name = self%definition%coordinates(i)%text
    end function model_coordinate_name

    !> Name of momentum i (1..n).
    function model_momentum_name(self, i) result(name)
        class(formula_model), intent(in) :: self
        integer, intent(in) :: i !! the momentum's index
        character(len=:), allocatable :: name
        name = self%definition%momenta(i)%text
    end function model_momentum_name

    !> Whether the model states an initial state.
    pure logical function model_has_initial_state(self) result(yes)
        class(formula_model), intent(in) :: self
        yes = self%definition%has_initial
    end function model_has_initial_state

    !> The file name, or the name given with the text.
    function model_source(self) result(name)
        class(formula_model), intent(in) :: self
        character(len=:), allocatable :: name
        name = ""
        if (allocated(self%definition%source)) name = self%definition%source
    end function model_source

    !> Instructions of the tapes: H, dH/dq, dH/dp, phi, Phi, Hessian of H, Hessians of phi.
    function model_tape_lengths(self) result(lengths)
        class(formula_model), intent(in) :: self
        integer :: lengths(7)
        lengths = [self%h_tape%length(), self%hq_tape%length(), self%hp_tape%length(), &
                   self%phi_tape%length(), self%jac_tape%length(), self%hess_tape%length(), &
                   self%phi_hess_tape%length()]
    end function model_tape_lengths

    !> Whether H has the separable form with constant masses.
    pure logical function model_is_separable(self) result(yes)
        class(formula_model), intent(in) :: self
        yes = self%separable
    end function model_is_separable

    !> A digest of the lines (with their ends): two polynomial hashes modulo 2**31 - 1, in
    !! hexadecimal (no integer overflow anywhere).
    function text_digest(lines) result(hex)
        type(text_line_t), intent(in) :: lines(:)
        character(len=16) :: hex
        integer(int64), parameter :: modulus = 2147483647_int64
        integer(int64) :: a, b
        integer :: k, c
        a = 0
        b = 1
        do k = 1, size(lines)
            do c = 1, len(lines(k)%text)
                call mix(iachar(lines(k)%text(c:c)))
            end do
            call mix(10)
        end do
        write (hex, '(2z8.8)') a, b
    contains
        subroutine mix(byte)
            integer, intent(in) :: byte
            a = modulo(a * 257 + byte, modulus)
            b = modulo(b * 65599 + byte, modulus)
        end subroutine mix
    end function text_digest

    !> The digest of the model's text.
    function model_text_digest(self) result(hex)
        class(formula_model), intent(in) :: self
        character(len=:), allocatable :: hex
        hex = trim(self%digest)
    end function model_text_digest

    !> Number of `event` statements.
    pure integer function model_event_count(self)
        class(formula_model), intent(in) :: self
        model_event_count = 0
        if (allocated(self%definition%events)) model_event_count = size(self%definition%events)
    end function model_event_count

    !> Name of event k (1..event_count).
    function model_event_name(self, k) result(name)
        class(formula_model), intent(in) :: self
        integer, intent(in) :: k
        character(len=:), allocatable :: name
        name = self%definition%event_names(k)%text
    end function model_event_name

    !> Direction of the crossings wanted from event k: -1 falling, 0 any, 1 rising.
    integer function model_event_direction(self, k)
        class(formula_model), intent(in) :: self
        integer, intent(in) :: k
        model_event_direction = self%definition%event_directions(k)
    end function model_event_direction

    !> Whether event k ends a run (`stop`).
    logical function model_event_stops(self, k)
        class(formula_model), intent(in) :: self
        integer, intent(in) :: k
        model_event_stops = self%definition%event_stops(k)
    end function model_event_stops

    !> The values of every event's expression at (q, p), with the current parameters.
    subroutine model_event_values(self, q, p, values)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: values(:) !! event_count values
        call self%event_tape%evaluate(q, p, self%values, values)
    end subroutine model_event_values

    ! ------------------------------------------------------------------ bindings

    function model_hamiltonian(self, q, p) result(energy)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        real(wp) :: out(1)
        call self%h_tape%evaluate(q, p, self%values, out)
        energy = out(1)
    end function model_hamiltonian

    subroutine model_dh_dq(self, q, p, gradient)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        call self%hq_tape%evaluate(q, p, self%values, gradient)
    end subroutine model_dh_dq

    subroutine model_dh_dp(self, q, p, gradient)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        call self%hp_tape%evaluate(q, p, self%values, gradient)
    end subroutine model_dh_dp

    subroutine model_dh_dq_double(self, q, p, gradient)
        class(formula_model), intent(in) :: self
        real(dp), intent(in) :: q(:), p(:)
        real(dp), intent(out) :: gradient(:)
        call self%hq_tape%evaluate_dp(q, p, self%values_dp, gradient)
    end subroutine model_dh_dq_double

    subroutine model_constraint(self, q, phi)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        real(wp) :: none(0)
        call self%phi_tape%evaluate(q, none, self%values, phi)
    end subroutine model_constraint

    subroutine model_constraint_jacobian(self, q, jacobian)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        real(wp) :: values(size(self%jac_rows)), none(0)
        integer :: e
        call self%jac_tape%evaluate(q, none, self%values, values)
        jacobian = 0
        do e = 1, size(values)
            jacobian(self%jac_rows(e), self%jac_cols(e)) = values(e)
        end do
    end subroutine model_constraint_jacobian

    subroutine model_constraint_sparsity(self, rows, columns)
        class(formula_model), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        rows = self%jac_rows
        columns = self%jac_cols
    end subroutine model_constraint_sparsity

    !> Phi at the pattern of `constraint_sparsity` (any other pattern: gathered from the
    !! whole Jacobian).
    subroutine model_constraint_values(self, q, rows, columns, values)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(out) :: values(:)
        real(wp) :: none(0)
        real(wp), allocatable :: jacobian(:, :)
        integer :: e
        if (size(rows) == size(self%jac_rows)) then
            if (all(rows == self%jac_rows) .and. all(columns == self%jac_cols)) then
                call self%jac_tape%evaluate(q, none, self%values, values)
                return
            end if
        end if
        allocate (jacobian(self%m, self%n))
        call self%constraint_jacobian(q, jacobian)
        do e = 1, size(rows)
            values(e) = jacobian(rows(e), columns(e))
        end do
    end subroutine model_constraint_values

    subroutine model_dh_dq_points(self, q, p, gradients)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:, :), p(:, :)
        real(wp), intent(out) :: gradients(:, :)
        call self%hq_tape%evaluate_points(q, p, self%values, gradients)
    end subroutine model_dh_dq_points

    subroutine model_dh_dp_points(self, q, p, gradients)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:, :), p(:, :)
        real(wp), intent(out) :: gradients(:, :)
        call self%hp_tape%evaluate_points(q, p, self%values, gradients)
    end subroutine model_dh_dp_points

    subroutine model_dh_dq_double_points(self, q, p, gradients)
        class(formula_model), intent(in) :: self
        real(dp), intent(in) :: q(:, :), p(:, :)
        real(dp), intent(out) :: gradients(:, :)
        call self%hq_tape%evaluate_points_dp(q, p, self%values_dp, gradients)
    end subroutine model_dh_dq_double_points

    subroutine model_constraint_points(self, q, phi)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:, :)
        real(wp), intent(out) :: phi(:, :)
        real(wp) :: none(0, size(q, 2))
        call self%phi_tape%evaluate_points(q, none, self%values, phi)
    end subroutine model_constraint_points

    !> Phi at a pattern at many points: one pass of the tape when the pattern is the
    !! model's own, else the entries gathered point by point.
    subroutine model_constraint_values_points(self, q, rows, columns, values)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:, :)
        integer, intent(in) :: rows(:), columns(:)
        real(wp), intent(out) :: values(:, :)
        real(wp) :: none(0, size(q, 2))
        integer :: j
        if (size(rows) == size(self%jac_rows)) then
            if (all(rows == self%jac_rows) .and. all(columns == self%jac_cols)) then
                call self%jac_tape%evaluate_points(q, none, self%values, values)
                return
            end if
        end if
        do j = 1, size(q, 2)
            call self%constraint_jacobian_values(q(:, j), rows, columns, values(:, j))
        end do
    end subroutine model_constraint_values_points

    subroutine model_potential_sparsity(self, rows, columns)
        class(formula_model), intent(in) :: self
        integer, allocatable, intent(out) :: rows(:), columns(:)
        rows = self%u_first
        columns = self%u_second
    end subroutine model_potential_sparsity

    subroutine model_hessian(self, q, p, hqq, hqp, hpp)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: hqq(:, :), hqp(:, :), hpp(:, :)
        real(wp) :: values(size(self%hess_first))
        integer :: e, i, k, n
        n = self%n
        call self%hess_tape%evaluate(q, p, self%values, values)
        hqq = 0
        hqp = 0
        hpp = 0
        do e = 1, size(values)
            i = self%hess_first(e)
            k = self%hess_second(e)
            if (k <= n) then
                hqq(i, k) = values(e)
                hqq(k, i) = values(e)
            else if (i <= n) then
                hqp(i, k - n) = values(e)
            else
                hpp(i - n, k - n) = values(e)
                hpp(k - n, i - n) = values(e)
            end if
        end do
    end subroutine model_hessian

    subroutine model_constraint_hessian(self, q, hessian)
        class(formula_model), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: hessian(:, :, :)
        real(wp) :: values(size(self%phi_hess_l)), none(0)
        integer :: e, i, k, l
        call self%phi_hess_tape%evaluate(q, none, self%values, values)
        hessian = 0
        do e = 1, size(values)
            l = self%phi_hess_l(e)
            i = self%phi_hess_first(e)
            k = self%phi_hess_second(e)
            hessian(i, k, l) = values(e)
            hessian(k, i, l) = values(e)
        end do
    end subroutine model_constraint_hessian

    !> The masses m_i = 1 / (d2H/dp_i^2) when H is separable with dH/dp = 0 at p = 0 and
    !! every m_i positive and finite at the current parameters; otherwise not declared.
    logical function model_diagonal_mass(self, mass) result(declared)
        class(formula_model), intent(in) :: self
        real(wp), intent(out) :: mass(:)
        real(wp) :: curvature(self%n), offset(self%n), zero(self%n)
        mass = 1
        declared = .false.
        if (.not. self%separable) return
        zero = 0
        call self%mass_tape%evaluate(zero, zero, self%values, curvature)
        call self%hp_tape%evaluate(zero, zero, self%values, offset)
        if (any(offset /= 0) .or. .not. all(is_finite(curvature))) return
        if (any(curvature <= 0)) return
        mass = 1 / curvature
        declared = all(is_finite(mass))
        if (.not. declared) mass = 1
    end function model_diagonal_mass

end module holosym_formula_model
