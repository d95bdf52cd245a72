//! The syntax tree of a `.slate` file, as written: names are not resolved and types are not
//! checked (the checker does that). Every node a later stage may report about has a [`Span`].
//!
//! `self` appears as an [`Ident`] named `self`: it is a keyword, so no declared name collides.

use slate_model::Context;

use crate::diagnostic::Span;

/// A parsed `.slate` source: its items in source order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct File {
    /// Classes, objects, active functions and plans, in source order.
    pub items: Vec<Item>,
}

impl File {
    /// The classes, in source order.
    pub fn classes(&self) -> impl Iterator<Item = &ClassDecl> {
        self.items.iter().filter_map(|item| match item {
            Item::Class(class) => Some(class),
            _ => None,
        })
    }

    /// The objects, in source order.
    pub fn objects(&self) -> impl Iterator<Item = &ObjectDecl> {
        self.items.iter().filter_map(|item| match item {
            Item::Object(object) => Some(object),
            _ => None,
        })
    }

    /// The top-level rules (`on write` active functions), in source order.
    pub fn rules(&self) -> impl Iterator<Item = &RuleDecl> {
        self.items.iter().filter_map(|item| match item {
            Item::Rule(rule) => Some(rule),
            _ => None,
        })
    }

    /// The plans, in source order.
    pub fn plans(&self) -> impl Iterator<Item = &PlanDecl> {
        self.items.iter().filter_map(|item| match item {
            Item::Plan(plan) => Some(plan),
            _ => None,
        })
    }

    /// The link policies (`link team { ... }`), in source order.
    pub fn links(&self) -> impl Iterator<Item = &LinkDecl> {
        self.items.iter().filter_map(|item| match item {
            Item::Link(link) => Some(link),
            _ => None,
        })
    }
}

/// A top-level declaration.
#[derive(Debug, Clone, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "a file has few items, built once; boxing would only add indirection to every match"
)]
pub enum Item {
    /// `class NAME [: PARENT] { ... }`
    Class(ClassDecl),
    /// `object NAME : CLASS ... ;` or with a body.
    Object(ObjectDecl),
    /// `on write OWNER.ATTRIBUTE { ... }`
    Rule(RuleDecl),
    /// `plan NAME { ... }`
    Plan(PlanDecl),
    /// `link NAME { ... }`: the loading module's policy for one kind of link.
    Link(LinkDecl),
}

impl Item {
    /// Where the whole item is.
    pub fn span(&self) -> Span {
        match self {
            Item::Class(class) => class.span,
            Item::Object(object) => object.span,
            Item::Rule(rule) => rule.span,
            Item::Plan(plan) => plan.span,
            Item::Link(link) => link.span,
        }
    }
}

/// A name as written, with its place.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Ident {
    /// The name.
    pub name: String,
    /// Where it is written.
    pub span: Span,
}

/// A string literal used as a name or an address (`owner "team/r1/nav"`, `to "team/r2/loco"`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct StrLit {
    /// The decoded text.
    pub value: String,
    /// Where the literal (with its quotes) is written.
    pub span: Span,
}

/// `class NAME [: PARENT] { attributes and active functions }`
#[derive(Debug, Clone, PartialEq)]
pub struct ClassDecl {
    /// The class name.
    pub name: Ident,
    /// The parent class; `None` means the root class `Thing`.
    pub parent: Option<Ident>,
    /// Attribute declarations, in source order.
    pub attributes: Vec<AttributeDecl>,
    /// `on write ATTRIBUTE { ... }` rules declared in the class, in source order.
    pub rules: Vec<RuleDecl>,
    /// The whole declaration.
    pub span: Span,
}

/// `NAME : TYPE option* ;` inside a class.
#[derive(Debug, Clone, PartialEq)]
pub struct AttributeDecl {
    /// The attribute name.
    pub name: Ident,
    /// The declared type.
    pub ty: TypeRef,
    /// `[m/s]`: the unit, raw text.
    pub unit: Option<Unit>,
    /// `in MIN .. MAX`
    pub bounds: Option<Bounds>,
    /// `step EXPR`: the resolution.
    pub step: Option<Expr>,
    /// `= EXPR [accuracy EXPR] [confidence EXPR]`: the default packet.
    pub default: Option<PacketExpr>,
    /// `derived = EXPR [accuracy EXPR] [confidence EXPR]`: computed on every read.
    pub derived: Option<PacketExpr>,
    /// `merge POLICY`: the name is validated by the checker.
    pub merge: Option<Ident>,
    /// `report ...`: when changes are sent to other boards.
    pub report: Option<ReportPolicyDecl>,
    /// The whole declaration, name to `;`.
    pub span: Span,
}

/// A type as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TypeRef {
    /// Which type.
    pub ty: Type,
    /// Where it is written.
    pub span: Span,
}

/// The value types of the language.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Type {
    /// `int`: 64-bit signed integer.
    Int,
    /// `real`: 64-bit float.
    Real,
    /// `bool`
    Bool,
    /// `string`
    String,
    /// `ref`: a token naming another object.
    Ref,
    /// `vec<N>`: N reals.
    Vec(u32),
}

/// `[raw text]` after an attribute type.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Unit {
    /// The text between the brackets, trimmed.
    pub text: String,
    /// Where the brackets are.
    pub span: Span,
}

/// `in MIN .. MAX`
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    /// Lowest allowed value.
    pub min: Expr,
    /// Highest allowed value.
    pub max: Expr,
}

/// A value with optional accuracy and confidence: `EXPR [accuracy EXPR] [confidence EXPR]`.
#[derive(Debug, Clone, PartialEq)]
pub struct PacketExpr {
    /// The value.
    pub value: Expr,
    /// The potential deviation, in the attribute's unit.
    pub accuracy: Option<Expr>,
    /// The probability that the value is right, in [0, 1].
    pub confidence: Option<Expr>,
}

/// `report` options of an attribute as written: when a change is worth sending (the checker
/// turns them into the model's `ReportPolicy`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ReportPolicyDecl {
    /// `every DURATION`: minimum interval between two reports.
    pub every: Option<Expr>,
    /// `heartbeat DURATION`: maximum interval between two reports.
    pub heartbeat: Option<Expr>,
    /// `deadband EXPR`: changes smaller than this are not sent.
    pub deadband: Option<Expr>,
    /// `on_accuracy`: send when the change exceeds the declared accuracy; its place if present.
    pub on_accuracy: Option<Span>,
    /// From `report` to the last option.
    pub span: Span,
}

/// `link NAME { entry* }`: what the loading module's ICI sends on one kind of link (`team`
/// or `robot`, validated by the checker). It belongs to no class, so class fingerprints do
/// not depend on it.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkDecl {
    /// The kind of link, as written.
    pub link: Ident,
    /// The entries, in source order.
    pub entries: Vec<LinkEntry>,
    /// The whole declaration.
    pub span: Span,
}

/// One statement of a `link` block.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkEntry {
    /// What it says.
    pub kind: LinkEntryKind,
    /// The whole statement, without its `;`.
    pub span: Span,
}

/// The statements of a `link` block.
#[derive(Debug, Clone, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "a link block has a handful of entries, built once; boxing would only add indirection"
)]
pub enum LinkEntryKind {
    /// `export CLASS [(CONTEXT, ...)], ...;`: classes that may leave the robot on this link.
    Export(Vec<ExportDecl>),
    /// `report CLASS.ATTRIBUTE (never | report options);`: this link's filter for the
    /// attribute, on top of the class's own.
    Report {
        /// `Class.attribute`.
        attribute: Path,
        /// `never`, or the report options.
        filter: LinkFilterDecl,
    },
    /// `heartbeat DURATION [timeout DURATION];`: the link's liveliness.
    Heartbeat {
        /// How long the link may stay silent before a heartbeat is sent.
        heartbeat: Expr,
        /// Silence after which a peer is dead.
        timeout: Option<Expr>,
    },
}

/// One class of an `export` line: `Robot` or `Robot (self, system)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportDecl {
    /// The class (and its subclasses).
    pub class: Ident,
    /// The contexts exported; empty means every context.
    pub contexts: Vec<ContextSpec>,
}

/// A link's filter for one attribute.
#[derive(Debug, Clone, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "a link block has a handful of entries, built once; boxing would only add indirection"
)]
pub enum LinkFilterDecl {
    /// `never`: the attribute does not go on this link; where `never` is written.
    Never(Span),
    /// The attribute report options (`every`, `heartbeat`, `deadband`, `on_accuracy`).
    Policy(ReportPolicyDecl),
}

/// `object NAME : CLASS [context C] [owner "addr"] ({ NAME = packet; ... } | ;)`
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectDecl {
    /// The object name.
    pub name: Ident,
    /// The class it is an instance of.
    pub class: Ident,
    /// SELF, SURROUNDINGS or SYSTEM.
    pub context: Option<ContextSpec>,
    /// The module that owns it (`owner "team/r1/nav"`).
    pub owner: Option<StrLit>,
    /// Initial attribute values, in source order.
    pub values: Vec<AttributeValue>,
    /// The whole declaration.
    pub span: Span,
}

/// A context as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ContextSpec {
    /// Which context.
    pub context: Context,
    /// Where its name is written.
    pub span: Span,
}

/// `NAME = EXPR [accuracy EXPR] [confidence EXPR];` in an object or `create` body.
#[derive(Debug, Clone, PartialEq)]
pub struct AttributeValue {
    /// The attribute.
    pub name: Ident,
    /// The packet written to it.
    pub packet: PacketExpr,
    /// Name to the end of the packet.
    pub span: Span,
}

/// A rule, the language's declarative active function: `on write ATTRIBUTE { actions }`, run
/// after the attribute is written.
///
/// In a class body `owner` is `None` (the enclosing class; `self` is the written instance); at
/// top level it names a class or an object (`on write Vehicle.speed`, `on write gsr.speed`).
#[derive(Debug, Clone, PartialEq)]
pub struct RuleDecl {
    /// The class or object whose attribute is watched; `None` inside a class.
    pub owner: Option<Ident>,
    /// The watched attribute.
    pub attribute: Ident,
    /// What runs after each write.
    pub actions: Vec<Action>,
    /// The whole rule.
    pub span: Span,
}

/// A production rule (paper p.3): once `initiation` has held and until `termination` holds, run
/// `action` each time `trigger` becomes true (or, with `every`, repeatedly while it holds).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanDecl {
    /// The plan name.
    pub name: Ident,
    /// `initiation: EXPR;` — absent means true.
    pub initiation: Option<Expr>,
    /// `trigger: EXPR;` — absent means true.
    pub trigger: Option<Expr>,
    /// `termination: EXPR;` — absent means false.
    pub termination: Option<Expr>,
    /// `every DURATION;` — repeat the action while the trigger holds.
    pub every: Option<Expr>,
    /// `action { ... }`
    pub action: Vec<Action>,
    /// The whole plan.
    pub span: Span,
}

/// One action statement.
#[derive(Debug, Clone, PartialEq)]
pub struct Action {
    /// What it does.
    pub kind: ActionKind,
    /// The whole statement.
    pub span: Span,
}

/// The actions a plan or an active function can take.
#[derive(Debug, Clone, PartialEq)]
pub enum ActionKind {
    /// `set TARGET = packet, ...;`
    Set(Vec<Assignment>),
    /// `report TARGET, ... [to "addr"];` — to everyone interested when `to` is absent.
    Report {
        /// Objects or object attributes to report.
        targets: Vec<Path>,
        /// The destination address.
        to: Option<StrLit>,
    },
    /// `send plan NAME { ... } to "addr";` or `send NAME to "addr";`
    Send {
        /// The plan sent.
        plan: PlanRef,
        /// The destination address.
        to: StrLit,
    },
    /// `create CLASS NAME [context C] [{ NAME = packet; ... }]`
    Create {
        /// The class of the new object.
        class: Ident,
        /// The new object's name.
        name: Ident,
        /// Its context.
        context: Option<ContextSpec>,
        /// Its initial attribute values.
        values: Vec<AttributeValue>,
    },
    /// `delete EXPR;`
    Delete(Expr),
}

/// A plan given inline or by name in a `send` action.
#[derive(Debug, Clone, PartialEq)]
pub enum PlanRef {
    /// `send plan NAME { ... }`
    Inline(Box<PlanDecl>),
    /// `send NAME`: a plan declared elsewhere.
    Named(Ident),
}

/// `TARGET = EXPR [accuracy EXPR] [confidence EXPR]` in a `set` action.
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    /// What is written (`gsr.speed`, `self.mode`, `Obstacle.clearance`).
    pub target: Path,
    /// The packet written.
    pub packet: PacketExpr,
    /// Target to the end of the packet.
    pub span: Span,
}

/// `NAME(.FIELD)*`: an object, class or variable, then attribute names.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Path {
    /// The first name (may be `self`).
    pub root: Ident,
    /// The attribute names after it.
    pub fields: Vec<Ident>,
    /// The whole path.
    pub span: Span,
}

/// An expression with its place.
///
/// Only the parser makes them, and it makes none deeper than
/// [`MAX_NESTING`](crate::MAX_NESTING): so every walk over the tree (checking, compiling,
/// evaluating, printing, dropping) may recurse on it.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    /// What it is.
    pub kind: ExprKind,
    /// Where it is written (parentheses excluded).
    pub span: Span,
    /// Operator levels below and including this node (see [`Expr::depth`]).
    depth: usize,
}

impl Expr {
    /// A literal or a name: no level.
    pub(crate) fn leaf(kind: ExprKind, span: Span) -> Expr {
        Expr {
            kind,
            span,
            depth: 0,
        }
    }

    /// A node over the expressions in `kind`, one level deeper than the deepest of them.
    pub(crate) fn node(kind: ExprKind, span: Span) -> Expr {
        let depth = 1 + kind
            .operands()
            .into_iter()
            .map(Expr::depth)
            .max()
            .unwrap_or(0);
        Expr { kind, span, depth }
    }

    /// How many levels of operators, `.`, calls, brackets and quantifiers the expression
    /// nests: 0 for a literal or a name, 1 for `a + b` or `a.x`, 2 for `-(a + b)`. At most
    /// [`MAX_NESTING`](crate::MAX_NESTING) for every parsed expression.
    pub fn depth(&self) -> usize {
        self.depth
    }
}

impl ExprKind {
    /// The expressions directly inside this one.
    fn operands(&self) -> Vec<&Expr> {
        match self {
            ExprKind::Literal(_) | ExprKind::Name(_) => Vec::new(),
            ExprKind::Vector(items) | ExprKind::Call(_, items) => items.iter().collect(),
            ExprKind::Field(inner, _) | ExprKind::Unary(_, inner) => vec![inner],
            ExprKind::Binary(_, lhs, rhs) => vec![lhs, rhs],
            ExprKind::Quantifier(q) => q
                .filter
                .iter()
                .chain(q.order.as_ref().map(|o| &o.key))
                .collect(),
        }
    }
}

/// The forms of expressions.
#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    /// A literal value.
    Literal(Literal),
    /// `[a, b, ...]`
    Vector(Vec<Expr>),
    /// A bare name: an object, a class, a quantifier variable or `self`.
    Name(Ident),
    /// `EXPR.NAME`: an attribute, or a packet field (`accuracy`, `confidence`, `timestamp`...).
    Field(Box<Expr>, Ident),
    /// `NAME(args)`: the checker validates the function and its arity.
    Call(Ident, Vec<Expr>),
    /// `not EXPR`, `-EXPR`
    Unary(UnaryOp, Box<Expr>),
    /// `EXPR op EXPR`
    Binary(BinaryOp, Box<Expr>, Box<Expr>),
    /// `any`, `all` or `count` over the objects of a class.
    Quantifier(Box<Quantifier>),
}

/// Literal values.
#[derive(Debug, Clone, PartialEq)]
pub enum Literal {
    /// `42`
    Int(i64),
    /// `2.5`, `1e-3`
    Real(f64),
    /// `250ms`, `2s`, `3min`: in seconds.
    Duration(f64),
    /// `"text"`, escapes decoded.
    Str(String),
    /// `true`, `false`
    Bool(bool),
    /// `none`: never written.
    None,
}

/// Prefix operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    /// `not`
    Not,
    /// `-`
    Neg,
}

/// Infix operators, loosest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    /// `or`
    Or,
    /// `and`
    And,
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `%`
    Rem,
}

impl BinaryOp {
    /// How the operator is written.
    pub fn as_str(self) -> &'static str {
        match self {
            BinaryOp::Or => "or",
            BinaryOp::And => "and",
            BinaryOp::Eq => "==",
            BinaryOp::Ne => "!=",
            BinaryOp::Lt => "<",
            BinaryOp::Le => "<=",
            BinaryOp::Gt => ">",
            BinaryOp::Ge => ">=",
            BinaryOp::Add => "+",
            BinaryOp::Sub => "-",
            BinaryOp::Mul => "*",
            BinaryOp::Div => "/",
            BinaryOp::Rem => "%",
        }
    }

    /// Whether this is one of the (non-associative) comparisons.
    pub fn is_comparison(self) -> bool {
        matches!(
            self,
            BinaryOp::Eq | BinaryOp::Ne | BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge
        )
    }
}

/// `any VAR : CLASS [where EXPR] [by EXPR [desc]]`, `all VAR : CLASS where EXPR`,
/// `count VAR : CLASS [where EXPR]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Quantifier {
    /// Which quantifier.
    pub kind: QuantifierKind,
    /// The variable bound to each object in turn (and, for `any`, to the match in the action).
    pub var: Ident,
    /// The class whose objects (subclasses included) are ranged over.
    pub class: Ident,
    /// `where EXPR`: the condition on the variable.
    pub filter: Option<Expr>,
    /// `by EXPR [desc]`: which match `any` binds (smallest key first, largest with `desc`).
    pub order: Option<Order>,
}

/// The three quantifiers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum QuantifierKind {
    /// True if some object matches; binds the first match.
    Any,
    /// True if every object matches.
    All,
    /// The number of matching objects.
    Count,
}

/// `by EXPR [desc]`
#[derive(Debug, Clone, PartialEq)]
pub struct Order {
    /// The sort key.
    pub key: Expr,
    /// Largest key first.
    pub descending: bool,
}
