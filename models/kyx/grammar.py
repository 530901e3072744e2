"""The KeYmaera X archive grammar (lark, LALR), after KeYmaera X's own `DLArchiveParser` and
`DLParser`: one expression grammar for terms and formulas (as KeYmaera X's parser does, so
`f(x)` and `p(x)` need no lookahead), programs with `;`-terminated atomic statements,
`++` choice, `{...}*` loops and `@invariant(...)` annotations on loops and ODEs. Tactic
blocks are read as opaque text and ignored."""

GRAMMAR = r"""
start: shared? entry+
     | block* problem tactic*                      -> bare_entry
     | expr                                        -> bare_formula

shared: "SharedDefinitions" "."? decl* END

// `.` after keywords and declarations: KeYmaera X 4's archive syntax (`R x.`), still in use
entry: KIND (IDENT ":")? STRING "."? meta* block* problem tactic* meta* END
KIND.2: "ArchiveEntry" | "Theorem" | "Lemma" | "Exercise"
meta: META_KEY STRING "."
META_KEY.2: "Description" | "Title" | "Link" | "Author" | "See" | "Illustration" | "Citation"
?block: definitions | variables
definitions: ("Definitions" | "Functions") "."? decl* END
variables: ("ProgramVariables" | "Variables") "."? vardecl* END
vardecl: SORT IDENT ("," IDENT)* _decl_end
decl: SORT IDENT ("," IDENT)* _decl_end                     -> decl_names
    | SORT IDENT "(" [params] ")" _decl_end                 -> decl_function
    | SORT IDENT ("(" [params] ")")? "=" expr _decl_end     -> def_term
    | SORT IDENT ("(" [params] ")")? "<->" expr _decl_end   -> def_formula
    | "HP" IDENT _decl_end                                  -> decl_program
    | "import" IDENT ("." IDENT)* ("." "{" IDENT ("," IDENT)* "}")? ";"  -> import_
    | "HP" IDENT "::=" braced _decl_end                     -> def_program
_decl_end: ";" | "."
params: param ("," param)*
param: SORT IDENT?
SORT.2: "Real" | "Bool" | "R" | "B"
problem: "Problem" "."? expr END
tactic: "Tactic" TACTIC_TEXT? END
TACTIC_TEXT: /(?:(?!End\.)[\s\S])+/

// ---- programs: a choice of sequences of statements
?program: sequence ("++" sequence)*                 -> choice
sequence: statement+
?statement: atomic ";"
          | braced ";"?
          | "if" "(" expr ")" "{" program "}" ("else" "{" program "}")? ";"?  -> if_then
atomic: IDENT ":=" expr                             -> assign
      | IDENT ":=" "*"                              -> havoc
      | DIFFSYM ":=" expr                           -> diff_assign
      | "?" expr                                    -> test
      | IDENT                                       -> program_call
braced: "{" program "}" STAR annotation*            -> loop
      | "{" program "}"                             -> group
      | "{" odes ("&" expr)? "}" annotation*        -> ode
odes: ode_eq ("," ode_eq)*
ode_eq: DIFFSYM "=" sum
annotation: ANNOTATION "(" expr ("," expr)* ")"
ANNOTATION: "@invariant" | "@variant"
STAR: "*"

// ---- expressions: formulas and terms, loosest first
?expr: equiv
?equiv: implication ("<->" implication)?
?implication: disjunction ("->" implication)?
            | disjunction REVIMP implication        -> reverse_implies
REVIMP.2: /<-(?=\s)/  // as KeYmaera X: `x<-1` is x < -1
?disjunction: conjunction ("|" conjunction)*
?conjunction: unary ("&" unary)*
?unary: "!" unary                                   -> not_
      | FORALL IDENT ("," IDENT)* unary             -> quantifier
      | EXISTS IDENT ("," IDENT)* unary             -> quantifier
      | "[" program "]" unary                       -> box
      | "<" program ">" unary                       -> diamond
      | comparison
?comparison: sum (CMP sum)?
CMP: "<=" | ">=" | "!=" | "=" | "<" | ">"
?sum: product (ADDOP product)*
ADDOP: "+" | "-"
?product: signed (MULOP signed)*
MULOP: STAR | "/"
?signed: "-" signed                                 -> neg
       | power
?power: postfix ("^" signed)?
?postfix: primary
        | "(" expr ")" "'"                          -> differential
?primary: NUMBER                                    -> number
        | IDENT                                     -> symbol
        | DIFFSYM                                   -> diffsym
        | IDENT "(" [expr ("," expr)*] ")"          -> call
        | "true"                                    -> true
        | "false"                                   -> false
        | "(" expr ")"
FORALL: "\\forall"
EXISTS: "\\exists"

END.2: "End" (WS_INLINE IDENT)? "."
DIFFSYM: /[A-Za-z][A-Za-z0-9_]*'/
IDENT: /[A-Za-z][A-Za-z0-9_]*/
NUMBER: /[0-9]+(\.[0-9]+)?/
STRING: /"(\\.|[^"\\])*"/
COMMENT: /\/\*[\s\S]*?\*\//
%import common.WS
%import common.WS_INLINE
%ignore WS
%ignore COMMENT
"""
