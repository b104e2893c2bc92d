!> category: internal module (use holosym)
!! The expression graph of a system given by formulas: every subexpression is a node,
!! stored once (hash-consing, so common subexpressions are shared wherever they occur),
!! built through constructors that simplify as they go (constants folded, x + 0, x * 1,
!! x - x, double negation, integer powers), and differentiated symbolically in reverse
!! mode: one sweep over the nodes a root depends on gives its whole gradient, itself as
!! nodes of the same graph, so second derivatives are gradients of gradients.
!!
!! Leaves are constants, variables (1..nvars: the coordinates, then the momenta) and
!! parameters (values that may change after the graph is built, so never folded). A
!! node's children always have smaller indices than the node, so index order is a
!! topological order; `varying` says whether a node depends on a variable.
!!
!! Node arguments of the constructors are passed by value: an operand is often read from
!! the graph's own arrays (`self%left(b)`), which a new node may reallocate.
!!
!! `evaluate_safely` evaluates nodes with every operation checked beforehand (domain,
!! division by zero, overflow), so that no floating-point exception is raised: it serves
!! constant folding and the diagnosis of a model at its initial state, and says which node
!! could not be evaluated and why. Fast repeated evaluation is the tape's
!! (`holosym_tape`).
module holosym_expression
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: is_finite
    implicit none
    private

    public :: expression_graph_t, operation_name, failure_text, locate_sorted

    !> Operation codes of the nodes (leaves first).
    integer, parameter, public :: op_constant = 1, op_variable = 2, op_parameter = 3, &
        op_negate = 4, op_add = 5, op_subtract = 6, op_multiply = 7, op_divide = 8, &
        op_power_int = 9, op_power = 10, op_sqrt = 11, op_exp = 12, op_log = 13, &
        op_sin = 14, op_cos = 15, op_tan = 16, op_atan = 17, op_sinh = 18, op_cosh = 19, &
        op_tanh = 20, op_asin = 21, op_acos = 22, op_atan2 = 23
    !> The largest operation code.
    integer, parameter, public :: last_operation = op_atan2

    !> The nodes made by `init`: the constants 0 and 1.
    integer, parameter, public :: node_zero = 1, node_one = 2

    !> Largest |k| of an integer power x^k kept as one node (a power beyond it stays the
    !! general x^y).
    integer, parameter, public :: max_integer_power = 1024

    !> Why an operation could not be evaluated (`evaluate_safely`).
    integer, parameter, public :: failure_none = 0, failure_division_by_zero = 1, &
        failure_overflow = 2, failure_domain = 3, failure_input = 4

    !> Modulus of the node hash (a prime below 2**31: products with the multiplier stay
    !! far inside int64).
    integer(int64), parameter :: hash_modulus = 2147483647_int64
    integer(int64), parameter :: hash_multiplier = 1000003_int64

    !> The graph.
    type :: expression_graph_t
        !> Number of nodes.
        integer :: count = 0
        !> Operation of each node (op_*).
        integer, allocatable :: op(:)
        !> First operand (a node), the variable index of op_variable, the parameter index
        !! of op_parameter.
        integer, allocatable :: left(:)
        !> Second operand (a node), the exponent of op_power_int, 0 otherwise.
        integer, allocatable :: right(:)
        !> Value of op_constant nodes.
        real(wp), allocatable :: value(:)
        !> Whether the node depends on a variable.
        logical, allocatable :: varying(:)
        !> Source line and column of the text the node first came from (0: derived).
        integer, allocatable :: line(:), column(:)
        integer, allocatable, private :: table(:)
        integer, allocatable, private :: mark(:)
        integer, allocatable, private :: adjoint(:)
        integer, private :: stamp = 0
    contains
        !> Start an empty graph (holding the constants 0 and 1).
        procedure :: init => graph_init
        !> The node of a constant.
        procedure :: constant => graph_constant
        !> The node of variable i.
        procedure :: variable => graph_variable
        !> The node of parameter k.
        procedure :: parameter => graph_parameter
        !> op(a): a simplified node.
        procedure :: unary => graph_unary
        !> a op b: a simplified node.
        procedure :: binary => graph_binary
        !> a^k for an integer k.
        procedure :: power_int => graph_power_int
        !> Record where a node came from (kept from its first occurrence).
        procedure :: locate => graph_locate
        !> Whether a node is a constant (and its value).
        procedure :: is_constant => graph_is_constant
        !> The nodes a set of roots depends on, in increasing order.
        procedure :: cone => graph_cone
        !> The variables a node depends on, in increasing order.
        procedure :: variables_of => graph_variables_of
        !> The parameters a node depends on, in increasing order.
        procedure :: parameters_of => graph_parameters_of
        !> Gradient of a node with respect to the variables 1..nvars.
        procedure :: gradient => graph_gradient
        !> Evaluate the cone of some roots with every operation checked.
        procedure :: evaluate_safely => graph_evaluate_safely
    end type expression_graph_t

contains

    ! ------------------------------------------------------------------ construction

    !> Start an empty graph with room for `capacity` nodes (it grows as needed).
    subroutine graph_init(self, capacity)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in), optional :: capacity !! expected number of nodes
        integer :: room, node
        room = 1024
        if (present(capacity)) room = max(room, capacity)
        if (allocated(self%op)) deallocate (self%op, self%left, self%right, self%value, &
                                            self%varying, self%line, self%column)
        allocate (self%op(room), self%left(room), self%right(room), self%value(room), &
                  self%varying(room), self%line(room), self%column(room))
        if (allocated(self%table)) deallocate (self%table)
        allocate (self%table(4 * room))
        self%table = 0
        if (allocated(self%mark)) deallocate (self%mark, self%adjoint)
        allocate (self%mark(room), self%adjoint(room))
        self%mark = 0
        self%adjoint = 0
        self%stamp = 0
        self%count = 0
        node = self%constant(0.0_wp)
        node = self%constant(1.0_wp)
    end subroutine graph_init

    !> The node of the constant `x` (finite; -0 is stored as 0).
    integer function graph_constant(self, x) result(node)
        class(expression_graph_t), intent(inout) :: self
        real(wp), intent(in) :: x !! the value
        real(wp) :: v
        v = x
        if (v == 0) v = 0
        node = intern(self, op_constant, 0, 0, v)
    end function graph_constant

    !> The node of variable `i` (1..nvars).
    integer function graph_variable(self, i) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: i !! variable index
        node = intern(self, op_variable, i, 0, 0.0_wp)
    end function graph_variable

    !> The node of parameter `k`.
    integer function graph_parameter(self, k) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: k !! parameter index
        node = intern(self, op_parameter, k, 0, 0.0_wp)
    end function graph_parameter

    !> Whether `node` is a constant; its value in `x`.
    logical function graph_is_constant(self, node, x) result(yes)
        class(expression_graph_t), intent(in) :: self
        integer, intent(in) :: node       !! the node
        real(wp), intent(out), optional :: x !! its value when constant
        yes = self%op(node) == op_constant
        if (present(x)) then
            x = 0
            if (yes) x = self%value(node)
        end if
    end function graph_is_constant

    !> Record the source position of `node` unless it has one.
    subroutine graph_locate(self, node, line, column)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: node, line, column !! the node and where it was written
        if (self%line(node) == 0) then
            self%line(node) = line
            self%column(node) = column
        end if
    end subroutine graph_locate

    !> op(a), simplified: constants folded (when the operation is safe), -(-x) = x,
    !! -(x - y) = y - x.
    recursive integer function graph_unary(self, op, a) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: op !! op_negate or a function (op_sqrt .. op_acos)
        integer, value :: a       !! the operand (a copy: the graph may grow meanwhile)
        real(wp) :: folded
        integer :: failure
        if (self%op(a) == op_constant) then
            call safe_apply(op, self%value(a), 0.0_wp, 0, folded, failure)
            if (failure == failure_none) then
                node = self%constant(folded)
                return
            end if
        end if
        if (op == op_negate) then
            select case (self%op(a))
            case (op_negate)
                node = self%left(a)
                return
            case (op_subtract)
                node = self%binary(op_subtract, self%right(a), self%left(a))
                return
            end select
        end if
        node = intern(self, op, a, 0, 0.0_wp)
    end function graph_unary

    !> a op b, simplified (see the module).
    recursive integer function graph_binary(self, op, a, b) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: op !! op_add, op_subtract, op_multiply, op_divide, op_power
                                  !! or op_atan2
        integer, value :: a, b  !! the operands (copies: the graph may grow meanwhile)
        real(wp) :: x, y, folded
        integer :: failure
        logical :: ca, cb
        ca = self%is_constant(a, x)
        cb = self%is_constant(b, y)
        if (ca .and. cb) then
            call safe_apply(op, x, y, 0, folded, failure)
            if (failure == failure_none) then
                node = self%constant(folded)
                return
            end if
        end if
        select case (op)
        case (op_add)
            node = simplified_sum(self, a, b, ca .and. x == 0, cb .and. y == 0)
        case (op_subtract)
            node = simplified_difference(self, a, b, ca .and. x == 0, cb .and. y == 0)
        case (op_multiply)
            node = simplified_product(self, a, b, ca, cb, x, y)
        case (op_divide)
            node = simplified_quotient(self, a, b, ca, cb, x, y)
        case (op_power)
            node = simplified_power(self, a, b, cb, y)
        case default
            node = intern(self, op, a, b, 0.0_wp)
        end select
    end function graph_binary

    !> a + b: 0 dropped, x + x = 2 x, x + (-y) = x - y, operands ordered.
    recursive integer function simplified_sum(self, a, b, a_zero, b_zero) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, value :: a, b
        logical, intent(in) :: a_zero, b_zero
        if (a_zero) then
            node = b
        else if (b_zero) then
            node = a
        else if (a == b) then
            node = self%binary(op_multiply, self%constant(2.0_wp), a)
        else if (self%op(b) == op_negate) then
            node = self%binary(op_subtract, a, self%left(b))
        else if (self%op(a) == op_negate) then
            node = self%binary(op_subtract, b, self%left(a))
        else
            node = intern(self, op_add, min(a, b), max(a, b), 0.0_wp)
        end if
    end function simplified_sum

    !> a - b: 0 dropped, x - x = 0, x - (-y) = x + y.
    recursive integer function simplified_difference(self, a, b, a_zero, b_zero) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, value :: a, b
        logical, intent(in) :: a_zero, b_zero
        if (b_zero) then
            node = a
        else if (a == b) then
            node = node_zero
        else if (a_zero) then
            node = self%unary(op_negate, b)
        else if (self%op(b) == op_negate) then
            node = self%binary(op_add, a, self%left(b))
        else
            node = intern(self, op_subtract, a, b, 0.0_wp)
        end if
    end function simplified_difference

    !> a b: 0 and 1 absorbed, -1 a negation, negations moved outside, constant factors
    !! collected, operands ordered.
    recursive integer function simplified_product(self, a, b, ca, cb, x, y) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, value :: a, b
        logical, intent(in) :: ca, cb
        real(wp), intent(in) :: x, y
        real(wp) :: inner, folded
        integer :: failure
        if ((ca .and. x == 0) .or. (cb .and. y == 0)) then
            node = node_zero
        else if (ca .and. x == 1) then
            node = b
        else if (cb .and. y == 1) then
            node = a
        else if (ca .and. x == -1) then
            node = self%unary(op_negate, b)
        else if (cb .and. y == -1) then
            node = self%unary(op_negate, a)
        else if (self%op(a) == op_negate) then
            node = self%unary(op_negate, self%binary(op_multiply, self%left(a), b))
        else if (self%op(b) == op_negate) then
            node = self%unary(op_negate, self%binary(op_multiply, a, self%left(b)))
        else if (cb .and. .not. ca) then
            node = self%binary(op_multiply, b, a)
        else
            node = 0
            if (ca .and. self%op(b) == op_multiply) then
                ! c1 (c2 x) = (c1 c2) x
                if (self%is_constant(self%left(b), inner)) then
                    call safe_apply(op_multiply, x, inner, 0, folded, failure)
                    if (failure == failure_none) node = self%binary(op_multiply, &
                        self%constant(folded), self%right(b))
                end if
            end if
            if (node == 0) then
                if (ca) then
                    node = intern(self, op_multiply, a, b, 0.0_wp)
                else
                    node = intern(self, op_multiply, min(a, b), max(a, b), 0.0_wp)
                end if
            end if
        end if
    end function simplified_product

    !> a / b: x / 1 = x, 0 / y = 0, x / x = 1, x / -1 = -x, negations moved outside.
    recursive integer function simplified_quotient(self, a, b, ca, cb, x, y) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, value :: a, b
        logical, intent(in) :: ca, cb
        real(wp), intent(in) :: x, y
        if (cb .and. y == 1) then
            node = a
        else if (cb .and. y == -1) then
            node = self%unary(op_negate, a)
        else if (ca .and. x == 0 .and. .not. (cb .and. y == 0)) then
            node = node_zero
        else if (a == b) then
            node = node_one
        else if (self%op(a) == op_negate) then
            node = self%unary(op_negate, self%binary(op_divide, self%left(a), b))
        else if (self%op(b) == op_negate) then
            node = self%unary(op_negate, self%binary(op_divide, a, self%left(b)))
        else
            node = intern(self, op_divide, a, b, 0.0_wp)
        end if
    end function simplified_quotient

    !> a^b: an integer constant exponent becomes an integer power, 1/2 a square root.
    recursive integer function simplified_power(self, a, b, cb, y) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, value :: a, b
        logical, intent(in) :: cb
        real(wp), intent(in) :: y
        if (cb) then
            if (abs(y) <= max_integer_power) then
                if (y == aint(y)) then
                    node = self%power_int(a, nint(y))
                    return
                end if
            end if
            if (y == 0.5_wp) then
                node = self%unary(op_sqrt, a)
                return
            end if
        end if
        node = intern(self, op_power, a, b, 0.0_wp)
    end function simplified_power

    !> a^k for an integer k: k = 0 gives 1, k = 1 gives a, constants folded, (x^j)^k =
    !! x^(j k), (-x)^k = +-x^k; |k| beyond `max_integer_power` stays the general power.
    recursive integer function graph_power_int(self, a, k) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, value :: a      !! the base (a copy: the graph may grow meanwhile)
        integer, intent(in) :: k !! the exponent
        real(wp) :: folded
        integer :: failure
        if (abs(k) > max_integer_power) then
            node = intern(self, op_power, a, self%constant(real(k, wp)), 0.0_wp)
        else if (k == 0) then
            node = node_one
        else if (k == 1) then
            node = a
        else if (self%op(a) == op_constant) then
            call safe_apply(op_power_int, self%value(a), 0.0_wp, k, folded, failure)
            if (failure == failure_none) then
                node = self%constant(folded)
            else
                node = intern(self, op_power_int, a, k, 0.0_wp)
            end if
        else if (self%op(a) == op_power_int .and. &
                 abs(real(self%right(a), wp) * k) <= max_integer_power) then
            node = self%power_int(self%left(a), self%right(a) * k)
        else if (self%op(a) == op_negate) then
            node = self%power_int(self%left(a), k)
            if (mod(k, 2) /= 0) node = self%unary(op_negate, node)
        else
            node = intern(self, op_power_int, a, k, 0.0_wp)
        end if
    end function graph_power_int

    !> The node (op, l, r, v), made if new.
    integer function intern(self, op, l, r, v) result(node)
        class(expression_graph_t), intent(inout) :: self
        integer, value :: op, l, r ! copies: `grow` reallocates the arrays they may come from
        real(wp), value :: v
        integer :: slot
        if (4 * (self%count + 1) > size(self%table)) call grow(self)
        slot = find_slot(self, op, l, r, v)
        if (self%table(slot) /= 0) then
            node = self%table(slot)
            return
        end if
        self%count = self%count + 1
        node = self%count
        self%op(node) = op
        self%left(node) = l
        self%right(node) = r
        self%value(node) = v
        self%line(node) = 0
        self%column(node) = 0
        select case (op)
        case (op_constant, op_parameter)
            self%varying(node) = .false.
        case (op_variable)
            self%varying(node) = .true.
        case (op_power_int)
            self%varying(node) = self%varying(l)
        case default
            self%varying(node) = self%varying(l)
            if (r > 0 .and. op /= op_power_int) &
                self%varying(node) = self%varying(node) .or. self%varying(r)
        end select
        self%table(slot) = node
    end function intern

    !> The table slot of (op, l, r, v): where it is, or the empty slot where it goes.
    integer function find_slot(self, op, l, r, v) result(slot)
        class(expression_graph_t), intent(in) :: self
        integer, intent(in) :: op, l, r
        real(wp), intent(in) :: v
        integer :: node
        slot = int(modulo(node_hash(op, l, r, v), int(size(self%table), int64))) + 1
        do
            node = self%table(slot)
            if (node == 0) return
            if (self%op(node) == op .and. self%left(node) == l .and. &
                self%right(node) == r) then
                if (op /= op_constant) return
                if (self%value(node) == v) return
            end if
            slot = slot + 1
            if (slot > size(self%table)) slot = 1
        end do
    end function find_slot

    !> Hash of a node's identity.
    pure integer(int64) function node_hash(op, l, r, v) result(h)
        integer, intent(in) :: op, l, r
        real(wp), intent(in) :: v
        integer(int64), allocatable :: bits(:)
        integer :: k
        h = op
        h = modulo(h * hash_multiplier + modulo(int(l, int64), hash_modulus), hash_modulus)
        h = modulo(h * hash_multiplier + modulo(int(r, int64), hash_modulus), hash_modulus)
        if (op == op_constant) then
            bits = transfer(v, [0_int64])
            do k = 1, size(bits)
                h = modulo(h * hash_multiplier + modulo(bits(k), hash_modulus), hash_modulus)
            end do
        end if
    end function node_hash

    !> Double the node arrays and the table.
    subroutine grow(self)
        class(expression_graph_t), intent(inout) :: self
        integer :: room, node, slot
        room = 2 * size(self%op)
        call resize_int(self%op, room)
        call resize_int(self%left, room)
        call resize_int(self%right, room)
        call resize_int(self%line, room)
        call resize_int(self%column, room)
        call resize_int(self%mark, room)
        call resize_int(self%adjoint, room)
        block
            real(wp), allocatable :: values(:)
            logical, allocatable :: flags(:)
            allocate (values(room), flags(room))
            values(:self%count) = self%value(:self%count)
            flags(:self%count) = self%varying(:self%count)
            call move_alloc(values, self%value)
            call move_alloc(flags, self%varying)
        end block
        deallocate (self%table)
        allocate (self%table(4 * room))
        self%table = 0
        do node = 1, self%count
            slot = find_slot(self, self%op(node), self%left(node), self%right(node), &
                             self%value(node))
            self%table(slot) = node
        end do
    end subroutine grow

    !> Resize an integer array to `room`, keeping its first entries (new ones 0).
    subroutine resize_int(array, room)
        integer, allocatable, intent(inout) :: array(:)
        integer, intent(in) :: room
        integer, allocatable :: larger(:)
        allocate (larger(room))
        larger = 0
        larger(:size(array)) = array
        call move_alloc(larger, array)
    end subroutine resize_int

    ! ------------------------------------------------------------------ traversal

    !> The nodes the roots depend on (the roots included), in increasing order.
    function graph_cone(self, roots) result(nodes)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: roots(:) !! the roots
        integer, allocatable :: nodes(:)
        integer, allocatable :: stack(:)
        integer :: top, node, used, k
        call next_stamp(self)
        allocate (stack(max(16, 2 * size(roots))), nodes(max(16, size(roots))))
        used = 0
        top = 0
        do k = 1, size(roots)
            call push(roots(k))
        end do
        do while (top > 0)
            node = stack(top)
            top = top - 1
            used = used + 1
            if (used > size(nodes)) call resize_int(nodes, 2 * size(nodes))
            nodes(used) = node
            select case (self%op(node))
            case (op_constant, op_variable, op_parameter)
            case (op_power_int)
                call push(self%left(node))
            case default
                call push(self%left(node))
                if (self%right(node) > 0) call push(self%right(node))
            end select
        end do
        nodes = sorted(nodes(:used))
    contains
        subroutine push(n)
            integer, intent(in) :: n
            if (self%mark(n) == self%stamp) return
            self%mark(n) = self%stamp
            top = top + 1
            if (top > size(stack)) call resize_int(stack, 2 * size(stack))
            stack(top) = n
        end subroutine push
    end function graph_cone

    !> The variables `node` depends on, in increasing order.
    function graph_variables_of(self, node) result(variables)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: node !! the node
        integer, allocatable :: variables(:)
        integer, allocatable :: nodes(:)
        nodes = self%cone([node])
        variables = pack(self%left(nodes), self%op(nodes) == op_variable)
        variables = sorted(variables)
    end function graph_variables_of

    !> The parameters `node` depends on, in increasing order.
    function graph_parameters_of(self, node) result(parameters)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: node !! the node
        integer, allocatable :: parameters(:)
        integer, allocatable :: nodes(:)
        nodes = self%cone([node])
        parameters = sorted(pack(self%left(nodes), self%op(nodes) == op_parameter))
    end function graph_parameters_of

    !> A new traversal stamp (marks of earlier traversals become stale).
    subroutine next_stamp(self)
        class(expression_graph_t), intent(inout) :: self
        if (self%stamp == huge(self%stamp)) then
            self%mark = 0
            self%stamp = 0
        end if
        self%stamp = self%stamp + 1
    end subroutine next_stamp

    !> The values in increasing order (heap sort: no recursion, n log n).
    pure function sorted(values) result(out)
        integer, intent(in) :: values(:)
        integer :: out(size(values))
        integer :: n, k, t
        out = values
        n = size(out)
        do k = n / 2, 1, -1
            call sift(out, k, n)
        end do
        do k = n, 2, -1
            t = out(1)
            out(1) = out(k)
            out(k) = t
            call sift(out, 1, k - 1)
        end do
    end function sorted

    !> Restore the heap order of a(start..last) below a(start).
    pure subroutine sift(a, start, last)
        integer, intent(inout) :: a(:)
        integer, intent(in) :: start, last
        integer :: root, child, swap
        root = start
        do
            child = 2 * root
            if (child > last) exit
            if (child < last) then
                if (a(child + 1) > a(child)) child = child + 1
            end if
            if (a(root) >= a(child)) exit
            swap = a(root)
            a(root) = a(child)
            a(child) = swap
            root = child
        end do
    end subroutine sift

    ! ------------------------------------------------------------------ differentiation

    !> d root / d variable_i for i = 1..nvars (node_zero where it does not depend on it):
    !! reverse mode over the cone of `root`, each adjoint a node of the graph.
    subroutine graph_gradient(self, root, nvars, gradient)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: root          !! the function
        integer, intent(in) :: nvars         !! number of variables
        integer, intent(out) :: gradient(:)  !! nvars nodes
        integer, allocatable :: nodes(:), adjoint(:)
        integer :: k, node, a
        gradient(:nvars) = node_zero
        if (.not. self%varying(root)) return
        nodes = self%cone([root])
        ! Adjoints by position in `nodes` (the graph grows during the sweep).
        allocate (adjoint(size(nodes)))
        adjoint = node_zero
        adjoint(size(nodes)) = node_one
        do k = size(nodes), 1, -1
            node = nodes(k)
            a = adjoint(k)
            if (a == node_zero) cycle
            if (self%op(node) == op_variable) then
                if (self%left(node) <= nvars) gradient(self%left(node)) = a
                cycle
            end if
            call propagate(self, node, a, nodes, adjoint)
        end do
    end subroutine graph_gradient

    !> Add the contributions of `node` (adjoint `a`) to the adjoints of its operands.
    subroutine propagate(self, node, a, nodes, adjoint)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: node, a
        integer, intent(in) :: nodes(:)
        integer, intent(inout) :: adjoint(:)
        integer :: l, r, t
        l = self%left(node)
        r = self%right(node)
        select case (self%op(node))
        case (op_add)
            call add(l, a)
            call add(r, a)
        case (op_subtract)
            call add(l, a)
            call add(r, neg(a))
        case (op_negate)
            call add(l, neg(a))
        case (op_multiply)
            call add(l, mul(a, r))
            call add(r, mul(a, l))
        case (op_divide)
            ! d(l/r) = dl / r - (l/r) dr / r
            call add(l, div(a, r))
            if (self%varying(r)) call add(r, neg(mul(a, div(node, r))))
        case (op_power_int)
            t = mul(self%constant(real(r, wp)), self%power_int(l, r - 1))
            call add(l, mul(a, t))
        case (op_power)
            ! d(l^r) = r l^(r-1) dl + l^r log(l) dr
            call add(l, mul(a, mul(r, self%binary(op_power, l, &
                self%binary(op_subtract, r, node_one)))))
            if (self%varying(r)) call add(r, mul(a, mul(node, fn(op_log, l))))
        case (op_sqrt)
            call add(l, div(a, mul(self%constant(2.0_wp), node)))
        case (op_exp)
            call add(l, mul(a, node))
        case (op_log)
            call add(l, div(a, l))
        case (op_sin)
            call add(l, mul(a, fn(op_cos, l)))
        case (op_cos)
            call add(l, neg(mul(a, fn(op_sin, l))))
        case (op_tan)
            call add(l, mul(a, plus_one(mul(node, node))))
        case (op_atan)
            call add(l, div(a, plus_one(mul(l, l))))
        case (op_sinh)
            call add(l, mul(a, fn(op_cosh, l)))
        case (op_cosh)
            call add(l, mul(a, fn(op_sinh, l)))
        case (op_tanh)
            call add(l, mul(a, self%binary(op_subtract, node_one, mul(node, node))))
        case (op_asin)
            call add(l, div(a, fn(op_sqrt, self%binary(op_subtract, node_one, mul(l, l)))))
        case (op_acos)
            call add(l, neg(div(a, fn(op_sqrt, self%binary(op_subtract, node_one, &
                mul(l, l))))))
        case (op_atan2)
            ! atan2(l, r): d = (r dl - l dr) / (l^2 + r^2)
            t = self%binary(op_add, mul(l, l), mul(r, r))
            call add(l, mul(a, div(r, t)))
            call add(r, neg(mul(a, div(l, t))))
        end select
    contains
        subroutine add(operand, contribution)
            integer, intent(in) :: operand, contribution
            integer :: position
            if (.not. self%varying(operand)) return
            position = locate_sorted(nodes, operand)
            adjoint(position) = self%binary(op_add, adjoint(position), contribution)
        end subroutine add
        integer function neg(x)
            integer, intent(in) :: x
            neg = self%unary(op_negate, x)
        end function neg
        integer function mul(x, y)
            integer, intent(in) :: x, y
            mul = self%binary(op_multiply, x, y)
        end function mul
        integer function div(x, y)
            integer, intent(in) :: x, y
            div = self%binary(op_divide, x, y)
        end function div
        integer function fn(op, x)
            integer, intent(in) :: op, x
            fn = self%unary(op, x)
        end function fn
        integer function plus_one(x)
            integer, intent(in) :: x
            plus_one = self%binary(op_add, node_one, x)
        end function plus_one
    end subroutine propagate

    !> Position of `value` in the increasing array `values` (which holds it).
    pure integer function locate_sorted(values, value) result(position)
        integer, intent(in) :: values(:), value
        integer :: low, high
        low = 1
        high = size(values)
        do while (low < high)
            position = (low + high) / 2
            if (values(position) < value) then
                low = position + 1
            else
                high = position
            end if
        end do
        position = low
    end function locate_sorted

    ! ------------------------------------------------------------------ evaluation

    !> Evaluate the cone of `roots` at the variables and parameters given, every operation
    !! checked before it is done (see `safe_apply`). On success `failed` is 0 and
    !! `values(node)` holds every node of the cone; otherwise `failed` is the first node
    !! (in index order) that could not be evaluated and `failure` says why.
    subroutine graph_evaluate_safely(self, roots, variables, parameters, values, failed, &
                                     failure)
        class(expression_graph_t), intent(inout) :: self
        integer, intent(in) :: roots(:)          !! the nodes wanted
        real(wp), intent(in) :: variables(:)     !! values of the variables
        real(wp), intent(in) :: parameters(:)    !! values of the parameters
        real(wp), allocatable, intent(inout) :: values(:) !! values by node (resized)
        integer, intent(out) :: failed           !! 0, or the node that failed
        integer, intent(out) :: failure          !! failure_* of that node
        integer, allocatable :: nodes(:)
        integer :: k, node
        real(wp) :: x, y
        failed = 0
        failure = failure_none
        if (.not. allocated(values)) allocate (values(self%count))
        if (size(values) < self%count) then
            deallocate (values)
            allocate (values(self%count))
        end if
        nodes = self%cone(roots)
        do k = 1, size(nodes)
            node = nodes(k)
            select case (self%op(node))
            case (op_constant)
                values(node) = self%value(node)
            case (op_variable)
                values(node) = variables(self%left(node))
                if (.not. is_finite(values(node))) failure = failure_input
            case (op_parameter)
                values(node) = parameters(self%left(node))
                if (.not. is_finite(values(node))) failure = failure_input
            case default
                x = values(self%left(node))
                y = 0
                if (self%op(node) /= op_power_int .and. self%right(node) > 0) &
                    y = values(self%right(node))
                call safe_apply(self%op(node), x, y, self%right(node), values(node), failure)
            end select
            if (failure /= failure_none) then
                failed = node
                return
            end if
        end do
    end subroutine graph_evaluate_safely

    !> result = op(x, y) (k: the exponent of op_power_int) for finite x, y, when it can be
    !! computed without a floating-point exception and gives a finite number; otherwise
    !! `failure` says why and result is 0.
    pure subroutine safe_apply(op, x, y, k, result, failure)
        integer, intent(in) :: op, k
        real(wp), intent(in) :: x, y
        real(wp), intent(out) :: result
        integer, intent(out) :: failure
        real(wp), parameter :: big = huge(1.0_wp) / 4
        ! log(huge) with a margin: exp, sinh and cosh of more overflow.
        real(wp) :: limit
        limit = 0.99_wp * log(huge(1.0_wp))
        result = 0
        failure = failure_none
        select case (op)
        case (op_negate)
            result = -x
        case (op_add, op_subtract)
            if (abs(x) > big .or. abs(y) > big) then
                failure = failure_overflow
            else if (op == op_add) then
                result = x + y
            else
                result = x - y
            end if
        case (op_multiply)
            if (x == 0 .or. y == 0) then
                result = 0
            else if (exponent(x) + exponent(y) >= maxexponent(x) - 1) then
                failure = failure_overflow
            else
                result = x * y
            end if
        case (op_divide)
            if (y == 0) then
                failure = failure_division_by_zero
            else if (x == 0) then
                result = 0
            else if (exponent(x) - exponent(y) >= maxexponent(x) - 1) then
                failure = failure_overflow
            else
                result = x / y
            end if
        case (op_power_int)
            call integer_power(x, k, result, failure)
        case (op_power)
            call real_power(x, y, limit, result, failure)
        case (op_sqrt)
            if (x < 0) then
                failure = failure_domain
            else
                result = sqrt(x)
            end if
        case (op_exp)
            if (x > limit) then
                failure = failure_overflow
            else if (x < -limit) then
                result = 0
            else
                result = exp(x)
            end if
        case (op_log)
            if (x <= 0) then
                failure = failure_domain
            else
                result = log(x)
            end if
        case (op_sin)
            result = sin(x)
        case (op_cos)
            result = cos(x)
        case (op_tan)
            result = tan(x)
            if (.not. is_finite(result)) failure = failure_overflow
        case (op_atan)
            result = atan(x)
        case (op_sinh, op_cosh)
            if (abs(x) > limit) then
                failure = failure_overflow
            else if (op == op_sinh) then
                result = sinh(x)
            else
                result = cosh(x)
            end if
        case (op_tanh)
            result = tanh(x)
        case (op_asin, op_acos)
            if (abs(x) > 1) then
                failure = failure_domain
            else if (op == op_asin) then
                result = asin(x)
            else
                result = acos(x)
            end if
        case (op_atan2)
            if (x == 0 .and. y == 0) then
                result = 0
            else
                result = atan2(x, y)
            end if
        case default
            failure = failure_domain
        end select
    end subroutine safe_apply

    !> x^k for an integer k, checked for division by zero and overflow.
    pure subroutine integer_power(x, k, result, failure)
        real(wp), intent(in) :: x
        integer, intent(in) :: k
        real(wp), intent(out) :: result
        integer, intent(out) :: failure
        failure = failure_none
        result = 0
        if (x == 0) then
            if (k < 0) then
                failure = failure_division_by_zero
            else if (k == 0) then
                result = 1
            end if
        else if (abs(real(exponent(x), wp) * k) + abs(k) >= maxexponent(x) - 1) then
            if (abs(x) > 1 .eqv. k > 0) then
                failure = failure_overflow
            else
                result = 0
            end if
        else
            result = x**k
        end if
    end subroutine integer_power

    !> x^y for a real y (x > 0, or x = 0 and y > 0), checked for overflow.
    pure subroutine real_power(x, y, limit, result, failure)
        real(wp), intent(in) :: x, y, limit
        real(wp), intent(out) :: result
        integer, intent(out) :: failure
        real(wp) :: scale
        failure = failure_none
        result = 0
        if (x < 0) then
            failure = failure_domain
        else if (x == 0) then
            if (y <= 0) failure = failure_division_by_zero
        else if (log(x) /= 0 .and. exponent(y) + exponent(log(x)) >= maxexponent(y) - 1) then
            if (y * sign(1.0_wp, log(x)) > 0) then
                failure = failure_overflow
            end if
        else
            scale = y * log(x)
            if (scale > limit) then
                failure = failure_overflow
            else if (scale >= -limit) then
                result = x**y
            end if
        end if
    end subroutine real_power

    !> The name of an operation as a model file writes it.
    pure function operation_name(op) result(name)
        integer, intent(in) :: op !! op_*
        character(len=:), allocatable :: name
        select case (op)
        case (op_negate); name = "unary minus"
        case (op_add); name = "'+'"
        case (op_subtract); name = "'-'"
        case (op_multiply); name = "'*'"
        case (op_divide); name = "'/'"
        case (op_power_int, op_power); name = "'^'"
        case (op_sqrt); name = "sqrt"
        case (op_exp); name = "exp"
        case (op_log); name = "log"
        case (op_sin); name = "sin"
        case (op_cos); name = "cos"
        case (op_tan); name = "tan"
        case (op_atan); name = "atan"
        case (op_sinh); name = "sinh"
        case (op_cosh); name = "cosh"
        case (op_tanh); name = "tanh"
        case (op_asin); name = "asin"
        case (op_acos); name = "acos"
        case (op_atan2); name = "atan2"
        case default; name = "value"
        end select
    end function operation_name

    !> What a failure of `evaluate_safely` means.
    pure function failure_text(failure) result(text)
        integer, intent(in) :: failure !! failure_*
        character(len=:), allocatable :: text
        select case (failure)
        case (failure_division_by_zero); text = "division by zero"
        case (failure_overflow); text = "overflow"
        case (failure_domain); text = "argument outside the domain"
        case (failure_input); text = "a value that is not finite"
        case default; text = "no failure"
        end select
    end function failure_text

end module holosym_expression
