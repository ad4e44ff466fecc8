//! The graph and the shape text are two views of one thing: every example
//! scene's shapes open as a graph that prints back to the same expression,
//! and edits of the graph print the shape text they should.

mod common;
use common::examples;

use egui_snarl::{InPinId, OutPinId};
use isoray_shape::syntax::{parse, without_spans};
use isoray_studio::graph::model::{self, from_objects, object_text, Form, GraphNode, Names, ObjectText};
use isoray_studio::graph::{same_shape, store, view, GraphEditor};
use isoray_studio::Document;

fn graph_of(text: &str) -> (Document, egui_snarl::Snarl<GraphNode>, Vec<egui_snarl::NodeId>, Names) {
    let doc = Document::from_text(text, None).unwrap();
    let names = Names::of(doc.scene());
    let (snarl, objects) = from_objects(&ObjectText::of_scene(doc.scene()), &names);
    (doc, snarl, objects, names)
}

#[test]
fn every_example_shape_opens_as_a_graph_and_prints_back_to_the_same_expression() {
    let mut objects_seen = 0;
    let mut nodes_seen = 0;
    let mut code_nodes = 0;
    for path in examples() {
        let doc = Document::open(&path).unwrap_or_else(|e| panic!("{}: {}", path.display(), e.rendered));
        let names = Names::of(doc.scene());
        let texts = ObjectText::of_scene(doc.scene());
        let (snarl, objects) = from_objects(&texts, &names);
        assert_eq!(objects.len(), doc.scene().objects.len());
        for (o, t) in objects.iter().zip(&texts) {
            let printed = object_text(&snarl, *o, &names)
                .unwrap_or_else(|e| panic!("{}: `{}` does not print: {}", path.display(), t.shape, e.message));
            let a = parse(&t.shape, 0).unwrap();
            let b = parse(&printed, 0).unwrap();
            if a.lets.is_empty() {
                assert_eq!(
                    without_spans(&a.body),
                    without_spans(&b.body),
                    "{}: `{}` printed as `{printed}`",
                    path.display(),
                    t.shape
                );
            } else {
                // A program with bindings is one code node, kept verbatim.
                assert_eq!(printed, t.shape);
                code_nodes += 1;
            }
            assert!(same_shape(&printed, &t.shape));
            objects_seen += 1;
            nodes_seen += model::preorder(&snarl, *o).len();
        }
        // Saving an unedited graph changes no shape: only the layout table is added.
        let mut doc2 = doc.clone();
        let mut editor = GraphEditor::of(&doc2);
        editor.commit(&mut doc2).unwrap();
        let before: Vec<String> = texts.iter().map(|t| t.shape.clone()).collect();
        let after: Vec<String> = ObjectText::of_scene(doc2.scene())
            .into_iter()
            .map(|t| t.shape)
            .collect();
        assert_eq!(before, after, "{}", path.display());
        assert!(doc2.text().contains("[[studio.graph]]"));
        // And `isoray render` ignores the table: the scene is the same.
        let again = isoray_scene::load_str(doc2.text(), &path.display().to_string(), &[]).unwrap();
        assert_eq!(again.objects.len(), doc.scene().objects.len());
    }
    assert!(objects_seen >= 60, "{objects_seen} objects");
    assert!(code_nodes >= 4, "the algebraic example's programs are code nodes");
    assert!(
        nodes_seen > 2 * objects_seen,
        "{nodes_seen} nodes for {objects_seen} objects"
    );
}

#[test]
fn a_shape_is_cut_at_its_primitives_operators_and_transforms() {
    let (_doc, snarl, objects, names) = graph_of(
        "[params]\nk = 0.3\n[[object]]\nshape = \"smooth_union(sphere(p - vec3(1.0, 0.0, 0.0), 0.5), box(rotate_y(p, 0.6), vec3(0.4)), k)\"\n",
    );
    let order = model::preorder(&snarl, objects[0]);
    let titles: Vec<String> = order.iter().map(|&n| snarl[n].title()).collect();
    assert_eq!(
        titles,
        ["object 0", "smooth_union", "sphere", "a - b", "box", "rotate_y", "k"]
    );
    // Numbers and vectors stay in the slots.
    let GraphNode::Op { slots, .. } = &snarl[order[3]] else {
        panic!()
    };
    assert_eq!(slots, &["p".to_string(), "vec3(1.0, 0.0, 0.0)".to_string()]);
    let GraphNode::Op { slots, .. } = &snarl[order[4]] else {
        panic!()
    };
    assert_eq!(slots[1], "vec3(0.4)");
    assert!(matches!(&snarl[order[6]], GraphNode::Param { name } if name == "k"));
    assert_eq!(
        object_text(&snarl, objects[0], &names).unwrap(),
        "smooth_union(sphere(p - vec3(1.0, 0.0, 0.0), 0.5), box(rotate_y(p, 0.6), vec3(0.4)), k)"
    );
}

#[test]
fn free_form_code_is_a_code_node_that_still_edits_as_text() {
    let (_doc, mut snarl, objects, names) =
        graph_of("[[object]]\nshape = '''\nlet q = p * 2.0; // scaled\nsphere(q, 1.0) / 2.0\n'''\n");
    let code = model::inputs_of(&snarl, objects[0])[0].unwrap();
    let GraphNode::Code { text } = &mut snarl[code] else {
        panic!("a code node")
    };
    assert!(text.contains("// scaled"));
    *text = "let q = p * 3.0;\nsphere(q, 1.0) / 3.0".into();
    assert_eq!(
        object_text(&snarl, objects[0], &names).unwrap(),
        "let q = p * 3.0;\nsphere(q, 1.0) / 3.0"
    );
    // A closed expression (no primitive) is code too, and it can feed an operator.
    let (_d, snarl, objects, names) = graph_of("[[object]]\nshape = \"length(p) - 1.0\"\n");
    let code = model::inputs_of(&snarl, objects[0])[0].unwrap();
    assert!(matches!(&snarl[code], GraphNode::Code { text } if text == "length(p) - 1.0"));
    assert_eq!(object_text(&snarl, objects[0], &names).unwrap(), "length(p) - 1.0");
}

#[test]
fn variadic_booleans_grow_and_compact_their_inputs() {
    let (_doc, mut snarl, objects, names) =
        graph_of("[[object]]\nshape = \"union(sphere(p, 1.0), box(p, vec3(0.5)), torus(p, 1.0, 0.2))\"\n");
    let u = model::inputs_of(&snarl, objects[0])[0].unwrap();
    // Three connected inputs and one more, empty, to grow.
    assert_eq!(snarl[u].inputs(), 4);
    let box_node = model::inputs_of(&snarl, u)[1].unwrap();
    // Disconnecting the middle one closes the gap: the torus moves up.
    snarl.disconnect(
        OutPinId {
            node: box_node,
            output: 0,
        },
        InPinId { node: u, input: 1 },
    );
    view::compact(&mut snarl, u, 1);
    assert_eq!(snarl[u].inputs(), 3);
    assert_eq!(
        object_text(&snarl, objects[0], &names).unwrap(),
        "union(sphere(p, 1.0), torus(p, 1.0, 0.2))"
    );
    // Two inputs are the least: disconnecting one more leaves an error.
    let torus = model::inputs_of(&snarl, u)[1].unwrap();
    snarl.disconnect(OutPinId { node: torus, output: 0 }, InPinId { node: u, input: 1 });
    view::compact(&mut snarl, u, 1);
    let e = object_text(&snarl, objects[0], &names).unwrap_err();
    assert_eq!(e.node, u);
    assert!(e.message.contains("input `b` needs a connection"), "{}", e.message);
}

#[test]
fn a_cycle_and_a_bad_value_are_errors_at_their_node() {
    let (_doc, mut snarl, objects, names) = graph_of("[[object]]\nshape = \"round(sphere(p, 1.0), 0.1)\"\n");
    let round = model::inputs_of(&snarl, objects[0])[0].unwrap();
    let sphere = model::inputs_of(&snarl, round)[0].unwrap();
    if let GraphNode::Op { slots, .. } = &mut snarl[sphere] {
        slots[1] = "1.0 +".into();
    }
    let e = object_text(&snarl, objects[0], &names).unwrap_err();
    assert_eq!(e.node, sphere);
    assert!(
        e.message.starts_with("input `r`: `1.0 +` does not parse"),
        "{}",
        e.message
    );
    if let GraphNode::Op { slots, .. } = &mut snarl[sphere] {
        slots[1] = "2.0".into();
    }
    // sphere's point input fed from round: a cycle.
    snarl.connect(OutPinId { node: round, output: 0 }, InPinId { node: sphere, input: 0 });
    let e = object_text(&snarl, objects[0], &names).unwrap_err();
    assert!(e.message.contains("cycle"), "{}", e.message);
}

#[test]
fn an_edited_graph_saves_as_shape_text_and_its_layout_in_the_studio_table() {
    let text = "# my scene\n[[object]]\nshape = \"sphere(p, 1.0)\" # the ball\n";
    let mut doc = Document::from_text(text, None).unwrap();
    let mut editor = GraphEditor::of(&doc);
    let sphere = model::inputs_of(&editor.snarl, editor.objects[0])[0].unwrap();
    if let GraphNode::Op { slots, .. } = &mut editor.snarl[sphere] {
        slots[1] = "1.5".into();
    }
    editor.snarl.get_node_info_mut(sphere).unwrap().pos = egui::pos2(12.0, 34.0);
    assert!(editor.commit(&mut doc).unwrap());
    assert!(doc.text().starts_with("# my scene\n"));
    assert!(
        doc.text().contains("shape = \"sphere(p, 1.5)\" # the ball"),
        "{}",
        doc.text()
    );
    let layouts = store::read(doc.text());
    assert_eq!(layouts.len(), 1);
    assert_eq!(layouts[0].nodes[1], [12.0, 34.0]);
    // Reopened, the node is where it was left.
    let reopened = GraphEditor::of(&doc);
    let s2 = model::inputs_of(&reopened.snarl, reopened.objects[0])[0].unwrap();
    assert_eq!(reopened.snarl.get_node_info(s2).unwrap().pos, egui::pos2(12.0, 34.0));
    // One undo step returns the old bytes.
    assert!(doc.undo());
    assert_eq!(doc.text(), text);
    // A new node from the palette makes a shape that loads.
    let entries = view::palette(&Names::default());
    let tw = view::matching(&entries, "twist_y");
    assert_eq!(tw.len(), 1);
    assert!(tw[0].doc.contains("twist"));
    let GraphNode::Op {
        form: Form::Call(n),
        slots,
    } = &tw[0].node
    else {
        panic!()
    };
    assert_eq!(
        (n.as_str(), slots.as_slice()),
        ("twist_y", &["p".to_string(), "0.25".to_string()][..])
    );
}
