!> category: internal module (use holosym)
!! The compiled form of a set of expressions: a tape, the straight-line program that
!! evaluates some nodes of an expression graph (holosym_expression) in one pass, with no
!! tree walk and no graph at run time.
!!
!! A tape's work array holds, in this order: the coordinates, momenta and parameters it
!! reads (only those), its constants, then one slot per instruction; each instruction
!! reads earlier slots. Outputs are slots. The program is one integer array (`code`, laid
!! out by holosym_tape_kernels.inc): the counts, the indices of the inputs, the
!! instructions as (operation, operand, operand) triples and the output slots, so that an
!! evaluation passes two arrays. The same tape evaluates in working precision (`evaluate`)
!! and in real64 (`evaluate_dp`, constants rounded once when the tape is built), at one
!! point or at many in one pass (`evaluate_points`, `evaluate_points_dp`: each instruction
!! decoded once for all the points, the same values as point by point).
!! Evaluation allocates nothing for tapes of up to `small_tape` slots, and is thread-safe:
!! a tape is only read.
module holosym_tape
    use holosym_kinds, only: wp, dp
    use holosym_expression, only: expression_graph_t, op_constant, op_variable, op_parameter, &
        op_power_int, locate_sorted
    use holosym_tape_kernels_wp, only: run_tape_wp, run_tape_points_wp, header_length, tape_lanes
    use holosym_tape_kernels_dp, only: run_tape_dp, run_tape_points_dp
    implicit none
    private

    public :: tape_t, rounded

    !> Slots of a tape evaluated in a fixed-size local array (larger tapes allocate one).
    integer, parameter :: small_tape = 512

    !> A compiled set of expressions.
    type :: tape_t
        !> Number of outputs.
        integer :: outputs = 0
        !> Slot of the first instruction's result.
        integer :: first = 1
        !> Size of the work array.
        integer :: slots = 0
        !> Number of instructions.
        integer :: instructions = 0
        !> The program (see holosym_tape_kernels.inc for its layout).
        integer, allocatable :: code(:)
        !> The constants, in working precision and rounded to real64.
        real(wp), allocatable :: constants(:)
        real(dp), allocatable :: constants_dp(:)
    contains
        !> Compile the nodes `roots` of a graph whose variables are n coordinates, then n
        !! momenta.
        procedure :: build => tape_build
        !> Evaluate in working precision.
        procedure :: evaluate => tape_evaluate
        !> Evaluate in real64.
        procedure :: evaluate_dp => tape_evaluate_dp
        !> Evaluate at many points in working precision.
        procedure :: evaluate_points => tape_evaluate_points
        !> Evaluate at many points in real64.
        procedure :: evaluate_points_dp => tape_evaluate_points_dp
        !> Number of instructions.
        procedure :: length => tape_length
    end type tape_t

contains

    !> Compile `roots` (outputs in this order) of `graph`; variables 1..n are the
    !! coordinates, n+1..2n the momenta.
    subroutine tape_build(self, graph, roots, n)
        class(tape_t), intent(out) :: self
        type(expression_graph_t), intent(inout) :: graph !! the expressions
        integer, intent(in) :: roots(:) !! the nodes to compute
        integer, intent(in) :: n        !! number of coordinates
        integer, allocatable :: nodes(:), slot(:), q_index(:), p_index(:), k_index(:)
        integer :: k, node, nq, np, nk, nc, ni, s, at
        nodes = graph%cone(roots)
        allocate (slot(size(nodes)))
        associate (op => graph%op(nodes), index => graph%left(nodes))
            q_index = pack(index, op == op_variable .and. index <= n)
            p_index = pack(index, op == op_variable .and. index > n) - n
            k_index = pack(index, op == op_parameter)
            self%constants = pack(graph%value(nodes), op == op_constant)
        end associate
        nq = size(q_index)
        np = size(p_index)
        nk = size(k_index)
        nc = size(self%constants)
        ni = size(nodes) - nq - np - nk - nc
        self%constants_dp = rounded(self%constants)
        self%first = nq + np + nk + nc + 1
        self%slots = size(nodes)
        self%instructions = ni
        self%outputs = size(roots)
        ! The layout of holosym_tape_kernels.inc: counts, inputs, triples, output slots.
        allocate (self%code(header_length + nq + np + nk + 3 * ni + size(roots)))
        self%code(1:header_length) = [nq, np, nk, nc, ni, size(roots)]
        at = header_length
        self%code(at + 1:at + nq) = q_index
        at = at + nq
        self%code(at + 1:at + np) = p_index
        at = at + np
        self%code(at + 1:at + nk) = k_index
        at = at + nk
        ! Slots: the leaves in the order of the packs above, then the instructions.
        call number_leaves(graph, nodes, n, nq, np, nk, slot)
        s = 0
        do k = 1, size(nodes)
            node = nodes(k)
            select case (graph%op(node))
            case (op_constant, op_variable, op_parameter)
                cycle
            end select
            s = s + 1
            slot(k) = self%first + s - 1
            self%code(at + 1) = graph%op(node)
            self%code(at + 2) = slot(locate_sorted(nodes, graph%left(node)))
            self%code(at + 3) = graph%right(node)
            if (graph%right(node) > 0 .and. graph%op(node) /= op_power_int) &
                self%code(at + 3) = slot(locate_sorted(nodes, graph%right(node)))
            at = at + 3
        end do
        do k = 1, size(roots)
            self%code(at + k) = slot(locate_sorted(nodes, roots(k)))
        end do
    end subroutine tape_build

    !> Slots of the leaves among `nodes`: coordinates 1..nq, momenta, parameters, constants.
    subroutine number_leaves(graph, nodes, n, nq, np, nk, slot)
        type(expression_graph_t), intent(in) :: graph
        integer, intent(in) :: nodes(:), n, nq, np, nk
        integer, intent(inout) :: slot(:)
        integer :: k, iq, ip, ik, ic
        iq = 0
        ip = nq
        ik = nq + np
        ic = nq + np + nk
        do k = 1, size(nodes)
            select case (graph%op(nodes(k)))
            case (op_variable)
                if (graph%left(nodes(k)) <= n) then
                    iq = iq + 1
                    slot(k) = iq
                else
                    ip = ip + 1
                    slot(k) = ip
                end if
            case (op_parameter)
                ik = ik + 1
                slot(k) = ik
            case (op_constant)
                ic = ic + 1
                slot(k) = ic
            end select
        end do
    end subroutine number_leaves

    !> Values rounded to real64 (beyond its range: the largest real64 of the sign, so that
    !! the conversion raises no overflow).
    pure function rounded(values) result(out)
        real(wp), intent(in) :: values(:)
        real(dp) :: out(size(values))
        integer :: k
        do k = 1, size(values)
            if (abs(values(k)) > huge(1.0_dp)) then
                out(k) = sign(huge(1.0_dp), real(sign(1.0_wp, values(k)), dp))
            else
                out(k) = real(values(k), dp)
            end if
        end do
    end function rounded

    !> The outputs at (q, p) with the parameters' values, in working precision.
    subroutine tape_evaluate(self, q, p, parameters, out)
        class(tape_t), intent(in) :: self
        real(wp), intent(in) :: q(:)          !! coordinates (n)
        real(wp), intent(in) :: p(:)          !! momenta (n)
        real(wp), intent(in) :: parameters(:) !! parameter values
        real(wp), intent(out) :: out(:)       !! the outputs
        real(wp) :: small(small_tape)
        real(wp), allocatable :: large(:)
        if (self%slots <= small_tape) then
            call run_tape_wp(self%code, self%constants, q, p, parameters, small, out)
        else
            allocate (large(self%slots))
            call run_tape_wp(self%code, self%constants, q, p, parameters, large, out)
        end if
    end subroutine tape_evaluate

    !> The outputs at (q, p) with the parameters' values, in real64.
    subroutine tape_evaluate_dp(self, q, p, parameters, out)
        class(tape_t), intent(in) :: self
        real(dp), intent(in) :: q(:)          !! coordinates (n)
        real(dp), intent(in) :: p(:)          !! momenta (n)
        real(dp), intent(in) :: parameters(:) !! parameter values, rounded
        real(dp), intent(out) :: out(:)       !! the outputs
        real(dp) :: small(small_tape)
        real(dp), allocatable :: large(:)
        if (self%slots <= small_tape) then
            call run_tape_dp(self%code, self%constants_dp, q, p, parameters, small, out)
        else
            allocate (large(self%slots))
            call run_tape_dp(self%code, self%constants_dp, q, p, parameters, large, out)
        end if
    end subroutine tape_evaluate_dp

    !> The outputs at the points (q(:, j), p(:, j)), j = 1..k, in working precision:
    !! out(:, j) as `evaluate` gives it at point j.
    subroutine tape_evaluate_points(self, q, p, parameters, out)
        class(tape_t), intent(in) :: self
        real(wp), intent(in) :: q(:, :)       !! coordinates (n x k)
        real(wp), intent(in) :: p(:, :)       !! momenta (n x k, or 0 x k: none read)
        real(wp), intent(in) :: parameters(:) !! parameter values
        real(wp), intent(out) :: out(:, :)    !! the outputs (outputs x k)
        real(wp) :: small(tape_lanes * small_tape)
        real(wp), allocatable :: large(:)
        integer :: k
        k = size(q, 2)
        if (k == 0) return
        if (self%slots <= small_tape) then
            call run_tape_points_wp(self%code, self%constants, k, q, max(1, size(q, 1)), p, &
                max(1, size(p, 1)), parameters, small, out, max(1, size(out, 1)))
        else
            allocate (large(tape_lanes * self%slots))
            call run_tape_points_wp(self%code, self%constants, k, q, max(1, size(q, 1)), p, &
                max(1, size(p, 1)), parameters, large, out, max(1, size(out, 1)))
        end if
    end subroutine tape_evaluate_points

    !> The outputs at the points (q(:, j), p(:, j)), j = 1..k, in real64: out(:, j) as
    !! `evaluate_dp` gives it at point j.
    subroutine tape_evaluate_points_dp(self, q, p, parameters, out)
        class(tape_t), intent(in) :: self
        real(dp), intent(in) :: q(:, :)       !! coordinates (n x k)
        real(dp), intent(in) :: p(:, :)       !! momenta (n x k, or 0 x k: none read)
        real(dp), intent(in) :: parameters(:) !! parameter values, rounded
        real(dp), intent(out) :: out(:, :)    !! the outputs (outputs x k)
        real(dp) :: small(tape_lanes * small_tape)
        real(dp), allocatable :: large(:)
        integer :: k
        k = size(q, 2)
        if (k == 0) return
        if (self%slots <= small_tape) then
            call run_tape_points_dp(self%code, self%constants_dp, k, q, max(1, size(q, 1)), &
                p, max(1, size(p, 1)), parameters, small, out, max(1, size(out, 1)))
        else
            allocate (large(tape_lanes * self%slots))
            call run_tape_points_dp(self%code, self%constants_dp, k, q, max(1, size(q, 1)), &
                p, max(1, size(p, 1)), parameters, large, out, max(1, size(out, 1)))
        end if
    end subroutine tape_evaluate_points_dp

    !> Number of instructions.
    pure integer function tape_length(self)
        class(tape_t), intent(in) :: self
        tape_length = self%instructions
    end function tape_length

end module holosym_tape
